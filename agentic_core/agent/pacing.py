"""How fast simulated time runs: as fast as it goes while the agent waits on the vehicle, at real time while the
agent waits on anything else (a model call, a tool, the operator), so a 2 s model call is 2 s of flight.

The vehicle's tick loop asks :meth:`Pace.speed` every tick; any thread of the agent marks its waits with
:meth:`Pace.waiting`.

>>> pace = Pace(None)
>>> with pace.waiting("vehicle"):
...     fast = pace.speed()
...     with pace.waiting("model"):
...         slow = pace.speed()
>>> fast, slow, pace.speed()
(None, 1.0, 1.0)
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Literal

WaitKind = Literal["vehicle", "model", "tool", "operator"]

URGENT_SPEED = 0.25
"""Times real time while the agent answers what it just saw (a 50 ms answer costs 12.5 ms of flight)."""


class Pace:
    """The speed of a simulated run, derived from what the agent is waiting on.

    ``speed`` is the run's setting (None: as fast as the machine goes; x: x times real time). While only the
    vehicle is awaited (a flight action flying) the simulation runs at that setting; while anything else is awaited,
    or the agent is computing between actions, at real time at most, so the world does not run ahead of the agent.
    """

    def __init__(self, speed: float | None) -> None:
        self.setting = speed
        self._lock = threading.Lock()
        self._vehicle = 0
        self._other = 0
        self._urgent = False

    def urgent(self, on: bool) -> None:
        """Slow the simulation to a crawl (:data:`URGENT_SPEED`) between a frame in which the agent saw something
        and its answer to it (a hold), so the answer comes at the same simulated moment, whatever the machine."""
        with self._lock:
            self._urgent = on

    @contextmanager
    def waiting(self, kind: WaitKind) -> Iterator[None]:
        """Mark a wait of ``kind`` for the duration of the block (re-entrant, any thread)."""
        with self._lock:
            if kind == "vehicle":
                self._vehicle += 1
            else:
                self._other += 1
        try:
            yield
        finally:
            with self._lock:
                if kind == "vehicle":
                    self._vehicle -= 1
                else:
                    self._other -= 1

    def speed(self) -> float | None:
        """The speed to run at now (None: as fast as possible)."""
        with self._lock:
            if self._urgent:
                return URGENT_SPEED
            flying = self._vehicle > 0 and self._other == 0
        if flying:
            return self.setting
        return 1.0 if self.setting is None else min(self.setting, 1.0)


__all__ = ["Pace", "WaitKind"]
