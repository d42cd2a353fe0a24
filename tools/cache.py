"""Results of idempotent tools kept for a while, keyed by their canonical arguments."""

from __future__ import annotations

import json
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Mapping
from typing import Any


def canonical_key(args: Mapping[str, Any]) -> str:
    """The same key for equal arguments, whatever their key order."""
    return json.dumps(args, sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=repr)


class ResultCache:
    """A TTL cache with a size bound (least recently used entries go first); thread-safe.

    >>> cache = ResultCache(ttl_s=60, clock=lambda: 0.0)
    >>> cache.put({"b": 1, "a": 2}, "sunny"); cache.get({"a": 2, "b": 1})
    (True, 'sunny')
    """

    def __init__(self, ttl_s: float, *, max_entries: int = 1024, clock: Callable[[], float] = time.monotonic) -> None:
        self.ttl_s = ttl_s
        self.max_entries = max_entries
        self.clock = clock
        self._lock = threading.Lock()
        self._entries: OrderedDict[str, tuple[float, Any]] = OrderedDict()
        self.hits = 0
        self.misses = 0

    def get(self, args: Mapping[str, Any]) -> tuple[bool, Any]:
        key = canonical_key(args)
        with self._lock:
            entry = self._entries.get(key)
            if entry is not None and entry[0] > self.clock():
                self._entries.move_to_end(key)
                self.hits += 1
                return True, entry[1]
            if entry is not None:
                del self._entries[key]
            self.misses += 1
            return False, None

    def put(self, args: Mapping[str, Any], value: Any) -> None:
        key = canonical_key(args)
        with self._lock:
            self._entries[key] = (self.clock() + self.ttl_s, value)
            self._entries.move_to_end(key)
            while len(self._entries) > self.max_entries:
                self._entries.popitem(last=False)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()

    def __len__(self) -> int:
        return len(self._entries)
