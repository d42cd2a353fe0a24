"""The run's SIGINT/SIGTERM handler never waits on a lock the main thread holds: Python runs it in the main thread
between two bytecodes, perhaps inside a ``with lock:`` the stop itself needs (the bus's, the trace's). A run
signalled at such a moment hung for good (seen once in the full suite: SIGTERM just after a landing, no ``control``
line in the trace, the process still there two minutes on)."""

from __future__ import annotations

import os
import signal
import threading
from types import SimpleNamespace
from typing import Any

import pytest

from agentic_core.run.cli import _signals_stop
from tests.waiting import wait_for

pytestmark = pytest.mark.timeout(30)


class LockedControl:
    """A control port whose abort needs ``lock``, as the run's needs the bus's and the trace's."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.aborted: list[tuple[str, str]] = []

    def stop_requested(self) -> str | None:
        return "abort" if self.aborted else None

    def abort(self, reason: str, *, by: str) -> None:
        with self.lock:
            self.aborted.append((reason, by))


def test_a_signal_while_the_main_thread_holds_the_stops_lock_stops_the_run_without_a_deadlock(
    capfd: Any,
) -> None:
    control, before = LockedControl(), signal.getsignal(signal.SIGTERM)
    with _signals_stop(SimpleNamespace(control=control)):  # type: ignore[arg-type]
        with control.lock:
            os.kill(os.getpid(), signal.SIGTERM)  # the handler runs here, in this thread, the lock held
            assert not control.aborted  # not yet: the stop waits for the lock, on a thread of its own
        wait_for(lambda: control.aborted, timeout_s=10.0, what="the stop, once the lock is free")
    assert control.aborted == [("SIGTERM received", "signal")]
    assert "SIGTERM: stopping the run (again to stop at once)" in capfd.readouterr().err
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is the run's only while it flies
