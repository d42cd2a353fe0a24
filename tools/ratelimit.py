"""Token-bucket rate limits per tool and per caller.

A limit is written ``"10/s"``, ``"30/min"``, ``"500/h"`` or ``"1000/day"``; the bucket holds ``burst`` tokens
(by default the count: ``"30/min"`` admits 30 at once, then one every 2 s). Over any interval of length T a bucket
admits at most ``rate × T + burst`` calls.
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass

from .errors import ToolDefinitionError

_UNITS = {"ms": 0.001, "s": 1.0, "sec": 1.0, "second": 1.0, "m": 60.0, "min": 60.0, "minute": 60.0}
_UNITS |= {"h": 3600.0, "hour": 3600.0, "d": 86400.0, "day": 86400.0}
_RATE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*/\s*([a-z]+)\s*$")


@dataclass(frozen=True)
class RateLimit:
    """``per_s`` calls a second on average, with bursts of up to ``burst``."""

    per_s: float
    burst: float
    text: str

    @classmethod
    def parse(cls, text: str, burst: float | None = None) -> RateLimit:
        match = _RATE.match(text.lower())
        word = match.group(2) if match else ""
        unit = _UNITS.get(word) or (_UNITS.get(word[:-1]) if word.endswith("s") else None)  # "mins", "hours"
        if not match or unit is None:
            raise ToolDefinitionError(f"rate limit {text!r}: write it as COUNT/UNIT, e.g. '10/s', '30/min', '500/h'")
        count = float(match.group(1))
        if count <= 0:
            raise ToolDefinitionError(f"rate limit {text!r}: the count must be positive")
        size = float(burst) if burst is not None else max(1.0, math.ceil(count))
        if size < 1:
            raise ToolDefinitionError(f"rate limit {text!r}: burst must be at least 1 (got {burst})")
        return cls(per_s=count / unit, burst=size, text=text.strip())


class _Bucket:
    __slots__ = ("stamp", "tokens")

    def __init__(self, tokens: float, stamp: float) -> None:
        self.tokens = tokens
        self.stamp = stamp


class RateLimiter:
    """Admits a call only if both the tool's bucket and the caller's bucket hold a token; thread-safe.

    >>> limiter = RateLimiter(RateLimit.parse("2/s"), None, clock=lambda: 0.0)
    >>> [limiter.acquire("pilot")[0] for _ in range(3)]
    [True, True, False]
    """

    MAX_CALLERS = 10_000  # per-caller buckets kept (least recently used dropped first; a dropped bucket is full)

    def __init__(
        self,
        tool_limit: RateLimit | None,
        caller_limit: RateLimit | None,
        *,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.tool_limit = tool_limit
        self.caller_limit = caller_limit
        self.clock = clock
        self._lock = threading.Lock()
        now = clock()
        self._tool = _Bucket(tool_limit.burst, now) if tool_limit else None
        self._callers: OrderedDict[str, _Bucket] = OrderedDict()

    @staticmethod
    def _refill(bucket: _Bucket, limit: RateLimit, now: float) -> None:
        if now > bucket.stamp:
            bucket.tokens = min(limit.burst, bucket.tokens + (now - bucket.stamp) * limit.per_s)
            bucket.stamp = now

    def acquire(self, caller: str) -> tuple[bool, float]:
        """``(True, 0)`` and a token taken from each bucket, or ``(False, seconds until a token is free)``."""
        with self._lock:
            now = self.clock()
            wait = 0.0
            pairs: list[tuple[_Bucket, RateLimit]] = []
            if self._tool is not None and self.tool_limit is not None:
                pairs.append((self._tool, self.tool_limit))
            if self.caller_limit is not None:
                bucket = self._callers.get(caller)
                if bucket is None:
                    bucket = self._callers[caller] = _Bucket(self.caller_limit.burst, now)
                    if len(self._callers) > self.MAX_CALLERS:
                        self._callers.popitem(last=False)
                else:
                    self._callers.move_to_end(caller)
                pairs.append((bucket, self.caller_limit))
            for bucket, limit in pairs:
                self._refill(bucket, limit, now)
                if bucket.tokens < 1.0:
                    wait = max(wait, (1.0 - bucket.tokens) / limit.per_s)
            if wait > 0:
                return False, wait
            for bucket, _ in pairs:
                bucket.tokens -= 1.0
            return True, 0.0

    def available(self) -> float | None:
        """Tokens in the tool's bucket now (None when the tool has no tool-wide limit)."""
        if self._tool is None or self.tool_limit is None:
            return None
        with self._lock:
            self._refill(self._tool, self.tool_limit, self.clock())
            return self._tool.tokens
