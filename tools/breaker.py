"""A circuit breaker per tool: after ``failure_threshold`` failures in a row it opens and refuses calls for
``reset_timeout_s``; then it lets one probe through (half-open): a success closes it, a failure opens it again."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

from .errors import ToolDefinitionError

BreakerState = Literal["closed", "open", "half_open"]


@dataclass(frozen=True)
class BreakerPolicy:
    failure_threshold: int = 5
    reset_timeout_s: float = 30.0

    def __post_init__(self) -> None:
        if self.failure_threshold < 1:
            raise ToolDefinitionError(f"breaker failure_threshold must be at least 1 (got {self.failure_threshold})")
        if self.reset_timeout_s <= 0:
            raise ToolDefinitionError(f"breaker reset_timeout_s must be positive (got {self.reset_timeout_s})")


class CircuitBreaker:
    """Thread-safe. Call :meth:`allow` before the tool runs, then exactly one of :meth:`success`,
    :meth:`failure` or :meth:`release` (the call ended without telling anything about the tool's health).

    >>> now = [0.0]
    >>> breaker = CircuitBreaker(BreakerPolicy(failure_threshold=1, reset_timeout_s=10), clock=lambda: now[0])
    >>> breaker.allow(); breaker.failure(); breaker.state
    (True, 0.0)
    'open'
    >>> now[0] = 10.0; breaker.state
    'half_open'
    """

    def __init__(self, policy: BreakerPolicy | None = None, *, clock: Callable[[], float] = time.monotonic) -> None:
        self.policy = policy or BreakerPolicy()
        self.clock = clock
        self._lock = threading.Lock()
        self._failures = 0
        self._opened_at: float | None = None
        self._probing = False
        self.transitions: list[tuple[float, BreakerState]] = []

    def _current(self, now: float) -> BreakerState:
        if self._opened_at is None:
            return "closed"
        return "half_open" if now - self._opened_at >= self.policy.reset_timeout_s else "open"

    @property
    def state(self) -> BreakerState:
        with self._lock:
            return self._current(self.clock())

    @property
    def consecutive_failures(self) -> int:
        return self._failures

    def allow(self) -> tuple[bool, float]:
        """``(True, 0)`` when the call may go ahead, else ``(False, seconds until a probe is let through)``."""
        allowed, wait, _ = self.admit()
        return allowed, wait

    def admit(self) -> tuple[bool, float, bool]:
        """:meth:`allow`, and whether the call let through is the half-open probe (pass that to :meth:`release`)."""
        with self._lock:
            now = self.clock()
            state = self._current(now)
            if state == "closed":
                return True, 0.0, False
            if state == "half_open" and not self._probing:
                self._probing = True
                return True, 0.0, True
            assert self._opened_at is not None
            if state == "half_open":  # a probe is out; its verdict comes soon
                return False, min(1.0, self.policy.reset_timeout_s), False
            return False, max(0.0, self._opened_at + self.policy.reset_timeout_s - now), False

    def success(self) -> None:
        with self._lock:
            self._failures = 0
            self._probing = False
            if self._opened_at is not None:
                self._opened_at = None
                self.transitions.append((self.clock(), "closed"))

    def failure(self) -> None:
        with self._lock:
            now = self.clock()
            self._failures += 1
            reopen = self._probing or self._opened_at is not None
            self._probing = False
            if reopen or self._failures >= self.policy.failure_threshold:
                self._opened_at = now
                self.transitions.append((now, "open"))

    def release(self, probe: bool = True) -> None:
        """The call ended without a verdict; if it was the probe, the next call may probe instead. A call let
        through while the breaker was closed frees nothing (another call may be the probe by now)."""
        if probe:
            with self._lock:
                self._probing = False
