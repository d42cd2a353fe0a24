"""What a stop's tool becomes when the aircraft is on the ground: the one rule the mission's abort and return and
the run's stops share.

Why: a return, or an abort whose ``on_abort`` is a return, would need a take-off, which PX4 (and our vehicle) deny
on the ground ("Return denied: not flying"); the run then reported a tool error for an aircraft that was exactly
where it should be. Disarmed on the ground there is nothing to do; armed (just landed, or spinning up to take off)
the aircraft lands in place, which disarms it.

>>> ground_tool("flight.rtl", {"landed_state": "on_ground", "armed": False}) is None
True
>>> ground_tool("flight.rtl", {"landed_state": "takeoff", "alt_m": 0.2, "armed": True})
'flight.land'
>>> ground_tool("flight.rtl", {"landed_state": "in_air", "alt_m": 30.0, "armed": True})
'flight.rtl'
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

LIFT_OFF_M = 0.5
"""Below this, an aircraft taking off has not yet left the ground."""


def on_the_ground(view: Mapping[str, Any]) -> bool:
    """The telemetry ``view`` says the aircraft is on the ground: landed, or spinning up and not yet clear of it."""
    state, alt = view.get("landed_state"), view.get("alt_m") or 0.0
    return state == "on_ground" or (state == "takeoff" and alt <= LIFT_OFF_M)


def ground_tool(tool: str, view: Mapping[str, Any]) -> str | None:
    """The tool to call for a stop's ``tool`` given the telemetry ``view``: None when the aircraft is on the ground,
    disarmed (nothing to do); ``flight.land`` when on the ground, armed, and ``tool`` would fly; else ``tool``."""
    if not on_the_ground(view):
        return tool
    if not view.get("armed"):
        return None
    return tool if tool == "flight.hold" else "flight.land"


__all__ = ["LIFT_OFF_M", "ground_tool", "on_the_ground"]
