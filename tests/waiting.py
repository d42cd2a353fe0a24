"""Waiting for a condition in tests, instead of sleeping a fixed time and hoping it was long enough.

>>> box = [1]
>>> wait_for(lambda: box, 1.0, what="a non-empty box")
[1]
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")

CONNECT_S = 30.0
"""How long a test waits for a vehicle's first HEARTBEAT. A healthy one answers within a simulated second; the
bound only has to outlast a stall of a loaded CI machine (5 s did not, once), and costs nothing when all is well."""


def wait_for(predicate: Callable[[], T], timeout_s: float, interval_s: float = 0.01, what: str = "the condition") -> T:
    """Poll ``predicate`` until it returns something truthy and return that; an AssertionError naming ``what``
    after ``timeout_s`` seconds. The predicate is asked once more at the deadline, so a slow machine is not
    failed by the last interval."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            value = predicate()
            if value:
                return value
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")
        time.sleep(interval_s)


async def wait_for_async(
    predicate: Callable[[], T], timeout_s: float, interval_s: float = 0.01, what: str = "the condition"
) -> T:
    """:func:`wait_for` on an event loop: the loop keeps running other tasks between polls."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() >= deadline:
            value = predicate()
            if value:
                return value
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")
        await asyncio.sleep(interval_s)
