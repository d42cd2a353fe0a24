"""Executor stand-ins for the dispatcher: one whose ``call`` takes an idempotency key (and, asked to, replays
the result it recorded for a key, as an executor that never repeats a side effect would), one whose ``call`` does
not; both run the real executor underneath and record what they were given."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from agentic_core.agent import Pace
from tools import ToolExecutor, ToolResult


class Crash(BaseException):
    """The process dies here (not an error the mission handles)."""


class Recorded:
    """What the dispatcher asked of an executor: (tool, args, key, the pace's speed at the call)."""

    def __init__(self, real: ToolExecutor, pace: Pace | None = None) -> None:
        self.real = real
        self.pace = pace
        self._lock = threading.Lock()
        self.calls: list[tuple[str, dict[str, Any], str | None, float | None]] = []
        self.before: Callable[[str, dict[str, Any]], None] | None = None

    def record(self, tool: str, args: dict[str, Any], key: str | None) -> None:
        with self._lock:
            self.calls.append((tool, dict(args), key, self.pace.speed() if self.pace is not None else None))
        if self.before is not None:
            self.before(tool, args)

    def keys(self, tool: str | None = None) -> list[str | None]:
        with self._lock:
            return [key for name, _, key, _ in self.calls if tool is None or name == tool]


class KeyedExecutor(Recorded):
    """An executor whose ``call`` accepts ``idempotency_key``; with ``replay`` it answers a key seen before with the
    result recorded for it and does not run the tool again."""

    def __init__(self, real: ToolExecutor, pace: Pace | None = None, *, replay: bool = False) -> None:
        super().__init__(real, pace)
        self.replay = replay
        self.results: dict[str, ToolResult] = {}
        self.replayed: list[str] = []

    def call(
        self, name: str, args: dict[str, Any] | None = None, *, timeout_s: float | None = None,
        idempotency_key: str | None = None,
    ) -> ToolResult:  # fmt: skip
        args = dict(args or {})
        with self._lock:
            if self.replay and idempotency_key is not None and idempotency_key in self.results:
                self.replayed.append(idempotency_key)
                return self.results[idempotency_key]
        self.record(name, args, idempotency_key)
        result = self.real.call(name, args, timeout_s=timeout_s)
        if idempotency_key is not None:
            with self._lock:
                self.results[idempotency_key] = result
        return result


class PlainExecutor(Recorded):
    """An executor whose ``call`` knows nothing of idempotency keys (passing one raises TypeError)."""

    def call(self, name: str, args: dict[str, Any] | None = None, *, timeout_s: float | None = None) -> ToolResult:
        self.record(name, dict(args or {}), None)
        return self.real.call(name, dict(args or {}), timeout_s=timeout_s)
