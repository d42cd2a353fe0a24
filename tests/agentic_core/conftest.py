"""Fixtures the end-to-end runs share."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.tools.builtin.conftest import Inbox, _start


@pytest.fixture
def smtp(monkeypatch: pytest.MonkeyPatch) -> Iterator[Any]:
    """An SMTP server on 127.0.0.1 that the run's alerts go to (``smtp.inbox.envelopes``)."""
    controller, server = _start(Inbox())
    monkeypatch.setenv("AGENTIC_UAV_SMTP_HOST", server.host)
    monkeypatch.setenv("AGENTIC_UAV_SMTP_PORT", str(server.port))
    monkeypatch.setenv("AGENTIC_UAV_SMTP_STARTTLS", "false")
    yield server
    controller.stop()
