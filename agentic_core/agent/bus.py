"""The run's event bus: every trace line is a :class:`~agentic_core.contracts.RunEvent` published here, and the
trace file, the terminal, the report and (later) the console are subscribers.

Publishing is synchronous and ordered: subscribers are called in the publishing thread, under the bus's lock, in
the order they subscribed, so every subscriber sees the same sequence. A subscriber that raises is dropped from
that one delivery and counted in :attr:`EventBus.errors`; it never breaks the run.

>>> bus = EventBus(clock=lambda: 3.0)
>>> seen = []
>>> _ = bus.subscribe(seen.append)
>>> event = bus.publish("log", summary="hello")
>>> event.seq, event.sim_t, seen[0].summary
(1, 3.0, 'hello')
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from ..contracts import RunEvent

Subscriber = Callable[[RunEvent], None]


class EventBus:
    """Numbers, stamps and delivers a run's events."""

    def __init__(self, *, clock: Callable[[], float | None] | None = None, first_seq: int = 0) -> None:
        self._clock = clock
        self._lock = threading.RLock()
        self._subscribers: list[Subscriber] = []
        self._seq = first_seq
        self.errors: list[str] = []

    def subscribe(self, subscriber: Subscriber) -> Callable[[], None]:
        """Add a subscriber; returns a function that removes it."""
        with self._lock:
            self._subscribers.append(subscriber)

        def unsubscribe() -> None:
            with self._lock:
                if subscriber in self._subscribers:
                    self._subscribers.remove(subscriber)

        return unsubscribe

    def publish(self, kind: str, /, **fields: Any) -> RunEvent:
        """Publish one event of ``kind`` with its fields; returns it as delivered."""
        sim_t = self._clock() if self._clock is not None else None
        with self._lock:
            self._seq += 1
            event = RunEvent(kind=kind, seq=self._seq, sim_t=None if sim_t is None else round(sim_t, 3), **fields)
            for subscriber in list(self._subscribers):
                try:
                    subscriber(event)
                except Exception as exc:  # a broken subscriber must not break the run
                    self.errors.append(
                        f"{getattr(subscriber, '__qualname__', subscriber)}: {type(exc).__name__}: {exc}"
                    )
        return event

    @property
    def seq(self) -> int:
        """The last sequence number published."""
        with self._lock:
            return self._seq


__all__ = ["EventBus", "Subscriber"]
