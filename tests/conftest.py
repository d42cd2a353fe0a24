"""What every test shares: no run streams to a ground station unless its test asks for one; an SMTP server for the
runs whose alerts should really go out; and, over several workers, the slow tests first."""

from __future__ import annotations

import os
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


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Over N xdist workers, put the ``slow`` tests (the flights) at the head of each of the N equal runs of the
    collection that ``--dist worksteal`` first hands the workers, a share each, a module's slow tests together (so
    a flight its module's tests share is flown once): every worker starts with its share of the flights and ends on
    quick tests, which the others can steal, instead of one worker flying the last flights alone while the rest
    wait. Only the order changes; without workers nothing does."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "0"))
    modules: dict[str, list[pytest.Item]] = {}
    for item in items:
        if item.get_closest_marker("slow") is not None:
            modules.setdefault(item.nodeid.split("::")[0], []).append(item)
    if workers < 2 or not modules:
        return
    shares: list[list[pytest.Item]] = [[] for _ in range(workers)]
    for group in sorted(modules.values(), key=len, reverse=True):
        min(shares, key=len).extend(group)
    slow = {id(item) for group in modules.values() for item in group}
    quick = [item for item in items if id(item) not in slow]
    ordered: list[pytest.Item] = []
    left = len(items)
    for worker, share in enumerate(shares):
        size = left // (workers - worker)  # as worksteal sizes its first hand-outs
        fill = max(size - len(share), 0)
        ordered += share + quick[:fill]
        del quick[:fill]
        left -= len(share) + fill
    items[:] = ordered + quick
