"""What a stop does to the aircraft, and what a resumed run does about it: the run's one place for the tools a stop
calls, the outcome it gives, going back to where a stop took the aircraft from, and where the aircraft ended.

>>> STOP_OUTCOMES["rtl"], stop_tool("abort", "land"), stop_tool("hold", "rtl")
('returned', 'flight.land', 'flight.hold')
>>> where_it_ended(None)
'where it was: no telemetry was heard'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..contracts.geodesy import local_offset
from ..contracts.policy_graph import ON_ABORT_TOOLS, OnAbort
from ..contracts.telemetry import TelemetrySample
from ..mission.grounded import ground_tool, on_the_ground

STOP_OUTCOMES = {"abort": "aborted", "rtl": "returned", "land": "landed", "hold": "held"}

Call = Callable[[str, dict[str, Any]], Any]
Publish = Callable[..., Any]


def stop_tool(command: str, on_abort: OnAbort) -> str:
    """The tool a stop calls: ``abort`` (the operator's, or Ctrl-C and SIGTERM) does what the mission's ``on_abort``
    says; ``rtl``, ``land`` and ``hold`` as said."""
    return ON_ABORT_TOOLS[on_abort if command == "abort" else command]  # an explicit stop names its own tool


def carry_out(command: str, on_abort: OnAbort, view: Mapping[str, Any], call: Call, publish: Publish) -> None:
    """Do what a stop asks of the aircraft; when that takes it away from where it was, say where that was
    (``stopped_at``), for a resumed run to go back to. On the ground a stop never starts a flight: disarmed, there
    is nothing to do; armed (just landed beside a casualty, or spinning up to take off), a return, which would
    need a take-off and which PX4 denies there, becomes a landing in place, which disarms."""
    alt = view.get("alt_m") or 0.0
    wanted = stop_tool(command, on_abort)
    tool = ground_tool(wanted, view)
    if tool is None:
        publish("log", level="info", summary=f"{command}: the aircraft is on the ground, disarmed: nothing to do")
        return
    if tool == "flight.land" and on_the_ground(view):
        publish("log", level="info", summary=f"{command}: the aircraft is on the ground, armed: landing in place "
                "(it disarms), not taking off")  # fmt: skip
        call(tool, {})
        return
    lat, lon = view.get("lat_deg"), view.get("lon_deg")
    landed = alt <= 0.5  # touching down or lifting off: not on the ground yet, as the vehicle reports it
    if tool != "flight.hold" and (view.get("armed") or not landed) and None not in (lat, lon):
        where = {"lat": lat, "lon": lon, "alt_m": round(float(alt), 1), "landed": landed}
        publish("log", level="info", stopped_at=where, summary=f"stopped at {lat:.6f}, {lon:.6f}, {alt:.1f} m: {tool}")
    call(tool, {})


GONE_M = 3.0
"""Farther than this from where a stop found it, a resumed run's aircraft goes back there first."""


def go_back(records: Sequence[Mapping[str, Any]], view: Mapping[str, Any], call: Call, publish: Publish) -> None:
    """A resumed run whose aircraft a stop took away (an abort with ``on_abort: rtl`` or ``land``) goes back to
    where the stop found it, so the mission goes on where it stopped (a casualty being answered is still there):
    it takes off again, to the height it last took off to, if the stop brought it down; then it flies back, and
    lands there if the stop found it landed. Nothing for a run with no stop in its records (the mission itself
    landed, say), nor for one that held where it was."""
    last_stop = max((k for k, r in enumerate(records) if r.get("kind") == "control"), default=None)
    if last_stop is None:
        return
    at = next((r["stopped_at"] for r in records[last_stop:] if r.get("stopped_at")), None)
    if at is None:
        return  # the stop held, or found the aircraft on the ground, disarmed: it is where the stop left it
    lifts = [r for r in records if r.get("kind") == "tool" and r.get("name") == "flight.takeoff"
             and r.get("status") == "ok"]  # fmt: skip
    took_off = bool(lifts) and view.get("landed_state") == "on_ground" and not view.get("armed")
    if took_off:
        publish("log", level="info", summary="resume: the stop brought the aircraft down; taking off again")
        call("flight.takeoff", dict(lifts[-1].get("args") or {}))
    lat, lon = view.get("lat_deg"), view.get("lon_deg")
    if lat is None or lon is None:
        return
    far = math.hypot(*local_offset(lat, lon, at["lat"], at["lon"])) > GONE_M
    if far:
        publish("log", level="info", summary="resume: going back to where the stop found the aircraft")
        call("flight.fly_to", {"lat": at["lat"], "lon": at["lon"], "alt_m": None if at.get("landed") else at["alt_m"]})
    if at.get("landed") and (far or took_off):
        call("flight.land", {"lat": at["lat"], "lon": at["lon"]})


def in_the_air(sample: TelemetrySample) -> bool:
    """Whether ``sample`` has the aircraft flying: not on the ground, nor at ground level landing or taking off."""
    low = sample.alt_m < 0.5 and (not sample.armed or sample.landed_state in ("landing", "takeoff"))
    return sample.landed_state != "on_ground" and not low


def where_it_ended(sample: TelemetrySample | None) -> str:
    """Where the aircraft is, as its last telemetry sample says, in words (for the trace and the report)."""
    if sample is None:
        return "where it was: no telemetry was heard"
    away = f"{math.hypot(sample.north_m, sample.east_m):.1f} m from home"
    if not in_the_air(sample):
        return f"on the ground, {'armed' if sample.armed else 'disarmed'}, {away}"
    return f"in the air at {sample.alt_m:.1f} m, {away} (mode {sample.mode})"


__all__ = ["GONE_M", "STOP_OUTCOMES", "carry_out", "go_back", "in_the_air", "stop_tool", "where_it_ended"]
