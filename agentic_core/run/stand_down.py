"""What a run that cannot go on does with an aircraft still in the air: the mission's ``on_abort``, never a hover
away from home. Why: a resumed run whose vehicle refused the fence, or one that hit a bug mid-flight, ended
``failed`` with the aircraft holding where it was.

>>> calls = []
>>> stand_down({"armed": True, "landed_state": "in_air", "alt_m": 10.0, "lat_deg": 21.4, "lon_deg": 39.9}, "rtl",
...            lambda tool, args: calls.append(tool), lambda *a, **k: None)
True
>>> calls
['flight.rtl']
>>> stand_down({"armed": False, "landed_state": "on_ground", "alt_m": 0.0}, "rtl", print, print)
False
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..contracts.policy_graph import OnAbort
from ..mission.grounded import on_the_ground
from .stops import Call, Publish, carry_out


def stand_down(view: Mapping[str, Any], on_abort: OnAbort, call: Call, publish: Publish) -> bool:
    """Carry out ``on_abort`` when the telemetry ``view`` says the aircraft is armed and off the ground (True);
    nothing otherwise (False). Never raises: the run is already ending on an error of its own."""
    if not view or not view.get("armed") or on_the_ground(view):
        return False
    publish("log", level="warning", summary=f"the run cannot go on with the aircraft in the air: on_abort {on_abort}")
    try:
        carry_out("abort", on_abort, view, call, publish)
    except Exception as exc:  # the vehicle's own failsafes remain; the report says what happened
        publish("log", level="error", error=f"{type(exc).__name__}: {exc}", summary=f"on_abort failed: {exc}")
    return True


__all__ = ["stand_down"]
