"""What every test shares: no run streams to a ground station unless its test asks for one; an SMTP server for the
runs whose alerts should really go out."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agentic_core.run.settings import GCS_ENV
from tests.shared_flights import MEDICAL_TEAM, route_alerts
from tests.tools.builtin.conftest import Inbox, _start

__all__ = ["MEDICAL_TEAM"]


@pytest.fixture(autouse=True)
def _no_ground_station(monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs default to ``--gcs none`` (``$AGENTIC_UAV_GCS``): a test that wants the stream names its own port."""
    monkeypatch.setenv(GCS_ENV, "none")


@pytest.fixture
def smtp(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """An SMTP server on 127.0.0.1 that the run's alerts go to (``smtp.inbox.envelopes``), with the medical team
    the missions mail configured as the alert recipients (the only addresses mail may go out to)."""
    controller, server = _start(Inbox())
    route_alerts(monkeypatch, server)
    yield server
    controller.stop()
