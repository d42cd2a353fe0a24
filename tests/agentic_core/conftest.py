"""Fixtures the end-to-end runs share."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.tools.builtin.conftest import Inbox, _start

MEDICAL_TEAM = "medical-team@example.org"
"""The medical team ``missions/hajj_emergency.yaml`` mails (its ``medical_team`` parameter's default)."""


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
