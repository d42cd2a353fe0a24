"""How fast the free-running vehicle flies: a fixed multiple of real time, as fast as possible, or a *pace*.

Why: an agent that waits on a model, a tool or an operator must see that time pass in the simulation too (a 2 s
model call is 2 s of simulated flight), yet nobody wants to wait in real time while the agent waits on the vehicle.
A pace is a callable asked before every tick for the speed to keep now; :class:`Pacer` keeps the wall/sim
reference, re-based whenever the answer changes so a switch brings no catch-up burst and no stall.

>>> speeds = iter([None, None, 1.0])
>>> pacer = Pacer(lambda: next(speeds), errors=[])
>>> pacer.speed, pacer.ask(), pacer.ask()
(None, None, 1.0)
>>> Pacer(-1.0, errors=[])
Traceback (most recent call last):
...
ValueError: speed must be positive or None
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, MutableSequence

Pace = Callable[[], float | None]
"""Asked every tick for the speed to run at now: a multiple of real time, or None for as fast as possible."""
Speed = float | None | Pace
"""What :meth:`~flight.mavlink.MavlinkVehicle.run` takes: a fixed speed or a pace."""


class Pacer:
    """The speed now, from a fixed speed or a pace. A pace that raises or answers something other than a positive
    number or None is recorded in ``errors`` and its last good answer kept (real time before any)."""

    def __init__(self, speed: Speed, errors: MutableSequence[str]) -> None:
        self._errors = errors
        if callable(speed):
            self.pace: Pace | None = speed
            self.speed: float | None = 1.0
            self.speed = self._answer()
        else:
            if speed is not None and not (speed > 0 and math.isfinite(speed)):
                raise ValueError("speed must be positive or None")
            self.pace = None
            self.speed = speed

    def ask(self) -> float | None:
        """The speed now (a fixed speed never changes)."""
        if self.pace is not None:
            self.speed = self._answer()
        return self.speed

    def changed(self) -> bool:
        """Whether the pace's answer now differs from the speed kept (without keeping it)."""
        return self.pace is not None and self._answer(record=False) != self.speed

    def _answer(self, record: bool = True) -> float | None:
        assert self.pace is not None
        try:
            answer = self.pace()
            if answer is None:
                return None
            value = float(answer)
            if not (value > 0 and math.isfinite(value)):
                raise ValueError(f"pace must be positive or None, not {answer!r}")
            return value
        except Exception as exc:  # a pacing bug must not stop the aircraft
            if record:
                self._errors.append(
                    f"pace {getattr(self.pace, '__qualname__', self.pace)}: {type(exc).__name__}: {exc}"
                )
            return self.speed


class ClockThread:
    """The daemon thread a clock loop (a vehicle's, or the swarm's lockstep) runs on, and the event that stops it."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.stop_event = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self, run: Callable[[Speed], None], speed: Speed) -> threading.Thread:
        """Run ``run(speed)`` on the thread; a bad speed raises here, in the caller's thread."""
        if self.thread is not None and self.thread.is_alive():
            raise RuntimeError("already running")
        if not callable(speed):
            Pacer(speed, [])
        self.stop_event.clear()
        self.thread = threading.Thread(target=run, args=(speed,), name=self.name, daemon=True)
        self.thread.start()
        return self.thread

    def stop(self) -> None:
        """Ask the loop to stop and wait for it (up to 5 s; not when called from the loop itself)."""
        self.stop_event.set()
        thread = self.thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)
        self.thread = None
