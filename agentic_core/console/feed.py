"""The live run as a stream for browsers: a :class:`LiveFeed` subscribes to the run's event bus, its telemetry
and its World Model, keeps what a page opened late needs (the events so far, the trail, the latest sample, the
pending questions), and hands every new message to each connected page's queue.

The run's threads publish; each page's stream reads on the server's event loop. A message crosses over with
``loop.call_soon_threadsafe``, so the publishing thread never waits on a browser: a page that falls more than
:data:`QUEUE_LIMIT` messages behind is dropped (it reconnects and starts from a fresh snapshot).

>>> feed = LiveFeed(telemetry_hz=10.0)
>>> feed.event({"kind": "log", "seq": 1, "summary": "hello"})
>>> feed.snapshot()["events"][0]["summary"]
'hello'
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

QUEUE_LIMIT = 2000
"""Messages a page may fall behind before it is dropped."""
EVENTS_KEPT = 2000
"""Events a page opened late is sent (the newest); the trace holds them all."""
TRAIL_STEP_S = 0.5
"""One trail point per half second of the vehicle's clock."""
TRAIL_KEPT = 20000


@dataclass
class Page:
    """One connected page: its queue and the loop that reads it."""

    queue: asyncio.Queue[str | None]
    loop: asyncio.AbstractEventLoop
    dropped: bool = False


class LiveFeed:
    """Thread-safe fan-out of one run's events, telemetry and World Model to the pages watching it."""

    def __init__(self, *, telemetry_hz: float = 10.0, clock: Callable[[], float] = time.monotonic) -> None:
        self._lock = threading.Lock()
        self._pages: list[Page] = []
        self._events: deque[dict[str, Any]] = deque(maxlen=EVENTS_KEPT)
        self._trail: deque[list[float]] = deque(maxlen=TRAIL_KEPT)
        self._sample: dict[str, Any] | None = None
        self._world: dict[str, Any] | None = None
        self._questions: dict[str, dict[str, Any]] = {}
        self._period = 1.0 / telemetry_hz
        self._clock = clock
        self._next_send = -1e9
        self._last_trail_t = -1e9
        self.static: dict[str, Any] = {}

    # ---- the run's side (any thread) ----

    def event(self, event: dict[str, Any]) -> None:
        """A run event (as JSON): kept and sent; an answered approval takes its question off the pages."""
        with self._lock:
            self._events.append(event)
            self._send_locked("event", event)
            if event.get("kind") == "control" and event.get("question") in self._questions:
                del self._questions[event["question"]]
                self._send_locked("answered", {"id": event["question"]})
            elif event.get("kind") == "approval" and event.get("status") != "asked" and self._questions:
                for gone in list(self._questions):  # timed out, or declined by a stop
                    del self._questions[gone]
                    self._send_locked("answered", {"id": gone})

    def question(self, question_id: str, request: dict[str, Any]) -> None:
        """A question the run waits on (an approval): a card on every page until answered."""
        with self._lock:
            self._questions[question_id] = {"id": question_id, "request": request}
            self._send_locked("question", self._questions[question_id])

    def asked(self, question_id: str) -> dict[str, Any] | None:
        """What the pending question ``question_id`` asks (its request), or None when none waits."""
        with self._lock:
            pending = self._questions.get(question_id)
            return dict(pending["request"]) if pending else None

    def telemetry(self, sample: dict[str, Any]) -> None:
        """A telemetry sample: kept; sent at most ``telemetry_hz`` times a second of wall time; a trail point
        every :data:`TRAIL_STEP_S` of the vehicle's clock."""
        with self._lock:
            self._sample = sample
            t = float(sample.get("time_s", 0.0))
            if t - self._last_trail_t >= TRAIL_STEP_S or t < self._last_trail_t:
                self._last_trail_t = t
                self._trail.append([round(t, 2), sample["lat_deg"], sample["lon_deg"], round(sample["alt_m"], 2)])
            now = self._clock()
            if now >= self._next_send:  # due times a period apart: a sample a little early is not skipped
                late = now - self._next_send
                self._next_send = self._next_send + self._period if late < self._period else now + self._period
                self._send_locked("telemetry", sample)

    def world(self, world: dict[str, Any]) -> None:
        """The World Model now (cut for the map): kept and sent."""
        with self._lock:
            self._world = world
            self._send_locked("world", world)

    # ---- the pages' side (the server's event loop) ----

    def snapshot(self) -> dict[str, Any]:
        """Everything a page needs to catch up."""
        with self._lock:
            return self._snapshot_locked()

    def connect(self, loop: asyncio.AbstractEventLoop) -> tuple[Page, str]:
        """A new page: its queue, and its first message (the snapshot), taken together so nothing falls between."""
        page = Page(asyncio.Queue(), loop)
        with self._lock:
            self._pages.append(page)
            first = _message("snapshot", self._snapshot_locked())
        return page, first

    def disconnect(self, page: Page) -> None:
        with self._lock:
            if page in self._pages:
                self._pages.remove(page)

    def close(self) -> None:
        """The run is over: every page's stream ends."""
        with self._lock:
            for page in self._pages:
                _put(page, None)
            self._pages.clear()

    @property
    def pages(self) -> int:
        with self._lock:
            return len(self._pages)

    # ---- internals ----

    def _snapshot_locked(self) -> dict[str, Any]:
        return {
            **self.static,
            "events": list(self._events),
            "trail": list(self._trail),
            "telemetry": self._sample,
            "world": self._world,
            "questions": list(self._questions.values()),
        }

    def _send_locked(self, kind: str, data: dict[str, Any]) -> None:
        text = _message(kind, data)
        for page in list(self._pages):
            if page.queue.qsize() >= QUEUE_LIMIT:
                page.dropped = True
                self._pages.remove(page)
                _put(page, None)
                continue
            _put(page, text)


def _put(page: Page, text: str | None) -> None:
    with contextlib.suppress(RuntimeError):  # a page's loop that has closed: nothing listens any more
        page.loop.call_soon_threadsafe(page.queue.put_nowait, text)


def _message(kind: str, data: dict[str, Any]) -> str:
    return json.dumps({"type": kind, "data": data}, separators=(",", ":"), default=str)


__all__ = ["EVENTS_KEPT", "QUEUE_LIMIT", "LiveFeed", "Page"]
