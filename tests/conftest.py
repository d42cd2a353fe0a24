"""What every test shares: no run streams to a ground station unless its test asks for one; an SMTP server for the
runs whose alerts should really go out."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agentic_core.run.settings import GCS_ENV
from tests.tools.builtin.conftest import Inbox, _start

MEDICAL_TEAM = "medical-team@example.org"
"""The medical team ``missions/hajj_emergency.yaml`` mails (its ``medical_team`` parameter's default)."""


@pytest.fixture(autouse=True)
def _no_ground_station(monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs default to ``--gcs none`` (``$AGENTIC_UAV_GCS``): a test that wants the stream names its own port."""
    monkeypatch.setenv(GCS_ENV, "none")


@pytest.fixture
def smtp(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """An SMTP server on 127.0.0.1 that the run's alerts go to (``smtp.inbox.envelopes``), with the medical team
    the missions mail configured as the alert recipients (the only addresses mail may go out to)."""
    controller, server = _start(Inbox())
    monkeypatch.setenv("AGENTIC_UAV_ALERT_RECIPIENTS", MEDICAL_TEAM)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_HOST", server.host)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_PORT", str(server.port))
    monkeypatch.setenv("AGENTIC_UAV_SMTP_STARTTLS", "false")
    yield server
    controller.stop()
