"""The operator console in the browser: a live run (its map, telemetry, the agent's timeline, approvals and
controls) and the replay of finished runs, served on 127.0.0.1 by :class:`ConsoleServer` (``agentic-uav
console``; ``agentic-uav run MISSION --console``). Needs the ``console`` extra (starlette, uvicorn, sse-starlette),
imported only when a server starts.

>>> from agentic_core.console import LiveFeed
>>> feed = LiveFeed()
>>> feed.telemetry({"time_s": 1.0, "lat_deg": 21.4, "lon_deg": 39.9, "alt_m": 10.0})
>>> feed.snapshot()["trail"]
[[1.0, 21.4, 39.9, 10.0]]
"""

from __future__ import annotations

from .access import Guard, check_bind
from .feed import LiveFeed
from .server import ConsoleOperator, ConsoleServer, watch

__all__ = ["ConsoleOperator", "ConsoleServer", "Guard", "LiveFeed", "check_bind", "watch"]
