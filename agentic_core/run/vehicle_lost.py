"""Whether the vehicle came home, or was lost: the run's outcome checked against what the aircraft last said.

Why: a run's outcome is what its graph and its stops meant to happen — ``returned`` once a return was asked for —
but over a link that has gone silent the return may never have been heard, and the aircraft was last seen in the
air. The outcome must be honest (exit 0 means completed or came home), so at the end of a run:

* a link silent for the mission's ``link_loss_s`` with the aircraft last seen in the air is ``lost`` (exit 1),
  whatever the run meant to do;
* a ``returned`` (or ``landed``) whose last return (or landing) failed, or whose aircraft is last seen in the air
  away from home, is ``failed``.

An aircraft on the ground where a stop landed it, or in the air with its link alive after a mission that ends
there, is as the run says.

>>> from agentic_core.contracts import TelemetrySample
>>> up = TelemetrySample(time_s=21.4, lat_deg=21.4, lon_deg=39.9, alt_m=10.0, north_m=44.0, east_m=4.0,
...                      down_m=-10.0, armed=True, landed_state="in_air", mode="hold")
>>> judge("returned", up, [], silent_s=14.6, link_loss_s=10.0).outcome
'lost'
>>> judge("returned", up, [], silent_s=0.1, link_loss_s=10.0).outcome
'failed'
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..contracts import TelemetrySample
from .stops import in_the_air

if TYPE_CHECKING:
    from .runner import MissionRun

LOST = "lost"
HOME_M = 5.0
"""Farther than this from home in the air, an aircraft has not come home."""
KEPT = ("failed", "interrupted")
"""Outcomes that stay as they are when the vehicle is lost (already a failure, or a run to resume); a note says it."""
STOP_TOOLS = {"returned": "flight.rtl", "landed": "flight.land"}
SILENT_MARGIN_S = 5.0
"""How much longer than the mission's ``link_loss_s`` an action waits on a silent vehicle: the failsafe acts first."""


@dataclass(frozen=True)
class Verdict:
    """The run's outcome after the check, and why it changed (or what the outcome leaves unsaid), if anything."""

    outcome: str
    note: str | None = None


def last_call_failed(records: Sequence[Mapping[str, Any]], tool: str) -> str | None:
    """The error of the last call of ``tool`` in the trace, when that call did not succeed (None otherwise)."""
    calls = [r for r in records if r.get("kind") == "tool" and r.get("name") == tool
             and r.get("status") not in ("started", "resumed")]  # fmt: skip
    if not calls or calls[-1].get("status") == "ok":
        return None
    return str(calls[-1].get("error") or calls[-1].get("status"))


def judge(
    outcome: str,
    last: TelemetrySample | None,
    records: Sequence[Mapping[str, Any]],
    *,
    silent_s: float | None,
    link_loss_s: float,
) -> Verdict:
    """``outcome`` checked against the last telemetry ``last``, the trace ``records`` and the link's silence at the
    end, ``silent_s`` seconds (None: never connected), judged against the mission's ``link_loss_s``."""
    if last is None:
        return Verdict(outcome)
    away = math.hypot(last.north_m, last.east_m)
    seen = f"last seen in the air at {last.alt_m:.1f} m, {away:.1f} m from home (mode {last.mode})"
    if silent_s is not None and silent_s > link_loss_s and in_the_air(last):
        heard = f"nothing heard for {silent_s:.0f} s" if math.isfinite(silent_s) else "its link closed"
        note = f"The vehicle was lost: {heard}, {seen}."
        return Verdict(outcome if outcome in KEPT else LOST, note)
    tool = STOP_TOOLS.get(outcome)
    if tool is None:
        return Verdict(outcome)
    error = last_call_failed(records, tool)
    if error is not None:
        return Verdict("failed", f"The {tool} asked for did not succeed ({error}); the aircraft ended {where(last)}.")
    if in_the_air(last) and away > HOME_M:
        return Verdict("failed", f"The aircraft did not come down: {seen}.")
    return Verdict(outcome)


def check_end(run: MissionRun, outcome: str) -> Verdict:
    """:func:`judge` for a run at its end: its last sample, its trace, its client's silence, its mission's limit."""
    client = run._client
    return judge(outcome, run.last_sample, run.trace.records, silent_s=client.silent_s if client is not None else None,
                 link_loss_s=run.plan.limits.link_loss_s)  # fmt: skip


def where(sample: TelemetrySample) -> str:
    """The aircraft's place in a few words."""
    away = math.hypot(sample.north_m, sample.east_m)
    return f"{'in the air at ' + format(sample.alt_m, '.1f') + ' m' if in_the_air(sample) else 'on the ground'}, " \
        f"{away:.1f} m from home"  # fmt: skip


def silence_bound(link_loss_s: float, default_s: float) -> float:
    """How long an action waits on a silent vehicle: the client's ``default_s``, but never before the mission's
    link failsafe has had its say (``link_loss_s`` and a margin).

    >>> silence_bound(10.0, 15.0), silence_bound(30.0, 15.0)
    (15.0, 35.0)
    """
    return max(default_s, link_loss_s + SILENT_MARGIN_S)


__all__ = ["HOME_M", "LOST", "Verdict", "check_end", "in_the_air", "judge", "last_call_failed", "silence_bound"]
