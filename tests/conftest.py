"""What every test shares: no run streams to a ground station unless its test asks for one."""

from __future__ import annotations

import pytest

from agentic_core.run.settings import GCS_ENV


@pytest.fixture(autouse=True)
def _no_ground_station(monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs default to ``--gcs none`` (``$AGENTIC_UAV_GCS``): a test that wants the stream names its own port."""
    monkeypatch.setenv(GCS_ENV, "none")
