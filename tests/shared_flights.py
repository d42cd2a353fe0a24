"""Flights shared by the tests of a module: each flown once, on the first test that reads it, and kept for the
module's other tests (under pytest-xdist, once per worker that runs one of them). Each flight has an SMTP server of
its own on 127.0.0.1, so what a test reads of its inbox is that flight's mail alone."""

from __future__ import annotations

from collections.abc import Callable, Hashable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Generic, TypeVar

import pytest

from agentic_core.run.settings import GCS_ENV
from tests.tools.builtin.conftest import Inbox, _start

MEDICAL_TEAM = "medical-team@example.org"
"""The medical team ``missions/hajj_emergency.yaml`` mails (its ``medical_team`` parameter's default)."""

T = TypeVar("T")


def route_alerts(monkeypatch: pytest.MonkeyPatch, server: Any) -> None:
    """Send a run's alerts to ``server`` (no TLS), with the medical team as the only address mail may go to."""
    monkeypatch.setenv("AGENTIC_UAV_ALERT_RECIPIENTS", MEDICAL_TEAM)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_HOST", server.host)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_PORT", str(server.port))
    monkeypatch.setenv("AGENTIC_UAV_SMTP_STARTTLS", "false")


@dataclass(frozen=True)
class Flown(Generic[T]):
    """What a shared flight returned, and the SMTP server that took its mail (``smtp.inbox.envelopes``)."""

    result: T
    smtp: Any


class SharedFlights:
    """Flights by key, each flown on first use in a folder of its own with the environment a test's own flight
    would have (no ground station, alerts to its own SMTP server), and the servers stopped at :meth:`close`."""

    def __init__(self, tmp: pytest.TempPathFactory) -> None:
        self._tmp = tmp
        self._flown: dict[Hashable, Flown[Any]] = {}
        self._stops: list[Callable[[], None]] = []

    def get(self, key: Hashable, fly: Callable[[Path], T]) -> Flown[T]:
        """The flight under ``key``: ``fly(folder)`` the first time, the same result after."""
        if key not in self._flown:
            controller, server = _start(Inbox())
            self._stops.append(controller.stop)
            with pytest.MonkeyPatch.context() as monkeypatch:
                monkeypatch.setenv(GCS_ENV, "none")
                route_alerts(monkeypatch, server)
                self._flown[key] = Flown(fly(self._tmp.mktemp("shared-flight")), server)
        flown: Flown[T] = self._flown[key]
        return flown

    def close(self) -> None:
        for stop in self._stops:
            stop()


@contextmanager
def shared_flights(tmp: pytest.TempPathFactory) -> Iterator[SharedFlights]:
    """:class:`SharedFlights` for the life of the block (a module-scoped fixture's)."""
    flights = SharedFlights(tmp)
    try:
        yield flights
    finally:
        flights.close()
