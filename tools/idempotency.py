"""Idempotency keys: what the executor needs so a side-effect tool never acts twice for one key.

A caller names an action with a key (the agent: ``"{run_id}:{step_id}:{attempt}"``); a re-run of the action (a
resumed run re-running its interrupted step) passes the same key. The executor looks the key up in its audit log
and replays a recorded ok result instead of calling the tool; :class:`KeyGate` makes a second call with a key
wait while a first one with that key runs, so the two cannot both act.

>>> gate, key = KeyGate(), ("alerts.notify", "run-1:alert:0")
>>> flight, mine = gate.claim(key)
>>> mine, gate.claim(key) == (flight, False)  # taken: a second caller waits for this flight
(True, True)
>>> gate.release(key, flight)
>>> gate.wait(flight, 0.0), gate.claim(key)[1]
(True, True)
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import threading
from collections.abc import Callable
from typing import Any

from .audit import redact
from .output_size import measure

MAX_KEY_LENGTH = 256
KEPT_OUTPUT_LIMIT_BYTES = 64 * 1024
"""The largest output (as JSON) the audit log keeps for a replay; a side-effect tool's receipt is far smaller."""

GateKey = tuple[str, str]  # (tool, idempotency key)


def key_problem(key: object) -> str | None:
    """Why ``key`` cannot be an idempotency key, or None: a non-empty string of at most 256 characters."""
    if not isinstance(key, str):
        return f"idempotency_key must be a string, not {type(key).__name__}"
    if not key.strip():
        return "idempotency_key must not be empty"
    if len(key) > MAX_KEY_LENGTH:
        return f"idempotency_key is {len(key)} characters long; at most {MAX_KEY_LENGTH}"
    return None


def header_value(key: str) -> str:
    """``key`` as an ``Idempotency-Key`` header value: itself when it is plain printable ASCII, else a digest of it.

    >>> header_value("run-1:alert:0"), len(header_value("ünïcode key"))
    ('run-1:alert:0', 64)
    """
    if key.isascii() and key.isprintable():
        return key
    return hashlib.sha256(key.encode()).hexdigest()


def kept_output(value: Any, sensitive: frozenset[str]) -> tuple[Any, bool, int]:
    """What the audit log keeps of a side-effect call's output: the redacted value, whether it is kept (not when
    its JSON is over :data:`KEPT_OUTPUT_LIMIT_BYTES`), and its size in bytes (counted no further than the limit)."""
    hidden = redact(value, sensitive)
    size, problem = measure(hidden, KEPT_OUTPUT_LIMIT_BYTES)  # counted, not serialised: it may be 1 MiB
    if problem is not None:  # too big, or not data a replay could return (a cycle)
        return None, False, size
    return hidden, True, size


class Flight:
    """One call holding a key; others wait for ``done``."""

    __slots__ = ("done", "waiters")

    def __init__(self) -> None:
        self.done = threading.Event()
        self.waiters: list[tuple[asyncio.AbstractEventLoop, asyncio.Future[None]]] = []


def _settle(future: asyncio.Future[None]) -> None:
    if not future.done():
        future.set_result(None)


class KeyGate:
    """The keys of side-effect calls running now in this executor, so two calls with one key run one at a time."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._flights: dict[GateKey, Flight] = {}

    def claim(self, key: GateKey) -> tuple[Flight, bool]:
        """The flight of ``key``, and whether the caller now holds it (release it when done); when it does not,
        another call with the key is running: wait for its flight, then claim again."""
        with self._lock:
            running = self._flights.get(key)
            if running is not None:
                return running, False
            flight = self._flights[key] = Flight()
            return flight, True

    def release(self, key: GateKey, flight: Flight) -> None:
        """Let the waiters of ``key`` go on (after the call's record is written, so they find it)."""
        with self._lock:
            if self._flights.get(key) is flight:
                del self._flights[key]
            waiters, flight.waiters = flight.waiters, []
            flight.done.set()
        for loop, future in waiters:
            with contextlib.suppress(RuntimeError):  # that loop is closed: nobody waits there any more
                loop.call_soon_threadsafe(_settle, future)

    def hold(self, key: GateKey, remaining: Callable[[], float | None]) -> tuple[GateKey, Flight] | None:
        """Claim ``key``, waiting while other calls hold it; None when ``remaining()`` seconds (None: no limit)
        ran out first."""
        while True:
            flight, mine = self.claim(key)
            if mine:
                return key, flight
            if not self.wait(flight, remaining()):
                return None

    async def ahold(self, key: GateKey, remaining: Callable[[], float | None]) -> tuple[GateKey, Flight] | None:
        """:meth:`hold` for callers on an event loop."""
        while True:
            flight, mine = self.claim(key)
            if mine:
                return key, flight
            if not await self.await_(flight, remaining()):
                return None

    def wait(self, flight: Flight, timeout: float | None) -> bool:
        """Wait for a running call to end; False when ``timeout`` seconds passed first."""
        return flight.done.wait(None if timeout is None else max(timeout, 0.0))

    async def await_(self, flight: Flight, timeout: float | None) -> bool:
        """:meth:`wait` for callers on an event loop (the loop keeps running meanwhile)."""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[None] = loop.create_future()
        with self._lock:
            if flight.done.is_set():
                return True
            flight.waiters.append((loop, future))
        try:
            async with asyncio.timeout(None if timeout is None else max(timeout, 0.0)):
                await future
            return True
        except TimeoutError:
            return False
        finally:
            with self._lock:
                if (loop, future) in flight.waiters:
                    flight.waiters.remove((loop, future))


__all__ = [
    "KEPT_OUTPUT_LIMIT_BYTES",
    "MAX_KEY_LENGTH",
    "Flight",
    "KeyGate",
    "header_value",
    "kept_output",
    "key_problem",
]
