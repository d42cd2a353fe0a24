"""The runnable examples in the flight modules' docstrings (this branch's public entry points)."""

import doctest
import importlib

import pytest

MODULES = [
    "flight.cli",
    "flight.client.safety",
    "flight.client.streams",
    "flight.client.telemetry",
    "flight.mavlink.guard",
    "flight.mavlink.links",
    "flight.mavlink.pacing",
    "flight.signing",
    "flight.sim.snapshot",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0
