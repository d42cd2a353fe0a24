"""The runnable examples in the swarm's docstrings stay true (as tests/agentic_core/test_docs.py does for the rest)."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [
    "agentic_core.contracts.swarm",
    "agentic_core.swarm",
    "agentic_core.swarm.signing",
    "agentic_core.swarm.card",
    "agentic_core.swarm.a2a_server",
    "agentic_core.swarm.a2a_client",
    "agentic_core.swarm.a2a_extra",
    "agentic_core.swarm.cost",
    "agentic_core.swarm.contract_net",
    "agentic_core.swarm.optimal",
    "agentic_core.swarm.deconflict",
    "agentic_core.swarm.fusion",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no runnable example"
    assert result.failed == 0
