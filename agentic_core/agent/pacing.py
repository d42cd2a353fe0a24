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
            flying = self._vehicle > 0 and self._other == 0
        if flying:
            return self.setting
        return 1.0 if self.setting is None else min(self.setting, 1.0)


__all__ = ["Pace", "WaitKind"]
