"""What a stop does to the aircraft, and what a resumed run does about it: the run's one place for the tools a stop
calls, the outcome it gives, re-taking off after a stop brought the aircraft down, and where the aircraft ended.

>>> STOP_OUTCOMES["rtl"], stop_tool("abort", "land"), stop_tool("abort", "land", by="signal")
('returned', 'flight.land', 'flight.hold')
>>> where_it_ended(None)
'where it was: no telemetry was heard'
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from ..contracts.policy_graph import ON_ABORT_TOOLS, OnAbort
from ..contracts.telemetry import TelemetrySample

STOP_TOOLS = {"rtl": "flight.rtl", "land": "flight.land", "hold": "flight.hold"}
"""What the aircraft does when the operator stops the run (``abort``: what the mission's ``on_abort`` says)."""

STOP_OUTCOMES = {"abort": "aborted", "rtl": "returned", "land": "landed", "hold": "held"}

Call = Callable[[str, dict[str, Any]], Any]
Publish = Callable[..., Any]


def stop_tool(command: str, on_abort: OnAbort, *, by: str | None = None) -> str:
    """The tool a stop calls: an operator's ``abort`` does what the mission's ``on_abort`` says; a stop by signal
    (Ctrl-C, SIGTERM) holds where it is, so that ``--resume`` goes on from there with the aircraft still over
    whatever it was attending to; ``rtl``, ``land`` and ``hold`` as said."""
    if command == "abort":
        return "flight.hold" if by == "signal" else ON_ABORT_TOOLS[on_abort]
    return STOP_TOOLS[command]


def carry_out(
    command: str, on_abort: OnAbort, view: Mapping[str, Any], call: Call, publish: Publish, *, by: str | None = None
) -> None:
    """Do what a stop asks of the aircraft (nothing for a landing asked of an aircraft on the ground, disarmed)."""
    if command == "land" and view.get("landed_state") == "on_ground" and not view.get("armed"):
        publish("log", level="info", summary="land: the aircraft is on the ground already")
        return
    call(stop_tool(command, on_abort, by=by), {})


def take_off_again(records: Sequence[Mapping[str, Any]], view: Mapping[str, Any], call: Call, publish: Publish) -> None:
    """A resumed run whose aircraft a stop brought down (an operator's abort with ``on_abort: rtl``, say) takes off
    again to the height it last took off to, so the mission goes on where it stopped; nothing for one still flying,
    nor for one the mission itself landed (no stop in the records)."""
    stops = [r for r in records if r.get("kind") == "control"]
    lifts = [r for r in records if r.get("kind") == "tool" and r.get("name") == "flight.takeoff"
             and r.get("status") == "ok"]  # fmt: skip
    if not stops or not lifts or view.get("landed_state") != "on_ground" or view.get("armed"):
        return
    publish("log", level="info", summary="resume: the stop brought the aircraft down; taking off again")
    call("flight.takeoff", dict(lifts[-1].get("args") or {}))


def where_it_ended(sample: TelemetrySample | None) -> str:
    """Where the aircraft is, as its last telemetry sample says, in words (for the trace and the report)."""
    if sample is None:
        return "where it was: no telemetry was heard"
    away = f"{math.hypot(sample.north_m, sample.east_m):.1f} m from home"
    if sample.landed_state == "on_ground" or (not sample.armed and sample.alt_m < 0.5):
        return f"on the ground, {'armed' if sample.armed else 'disarmed'}, {away}"
    return f"in the air at {sample.alt_m:.1f} m, {away} (mode {sample.mode})"


__all__ = ["STOP_OUTCOMES", "STOP_TOOLS", "carry_out", "stop_tool", "take_off_again", "where_it_ended"]
