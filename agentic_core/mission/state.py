"""The state of a compiled mission in the graph (checkpointed as it is), and how its channels merge."""

from __future__ import annotations

import operator
from typing import Annotated, Any, TypedDict

FINISHED = frozenset({"ok", "skipped", "failed", "replaced", "preempted", "cancelled"})
"""Step statuses that end a step."""


def merge(left: dict[str, Any], right: dict[str, Any]) -> dict[str, Any]:
    return {**left, **right}


def merge_status(left: dict[str, str], right: dict[str, str]) -> dict[str, str]:
    """A finished step stays finished: a 'scheduled' or 'blocked' written in the same superstep as its end
    (whatever the order writes are applied in) does not bring it back."""
    out = dict(left)
    for step_id, status in right.items():
        if out.get(step_id) in FINISHED and status not in FINISHED:
            continue
        out[step_id] = status
    return out


def merge_latched(left: dict[str, Any], right: dict[str, Any]) -> dict[str, Any]:
    """Latches set (an event) and cleared (None) per trigger."""
    out = {**left, **right}
    return {k: v for k, v in out.items() if v is not None}


def worst(left: str | None, right: str | None) -> str | None:
    """Two halts in one superstep: returning home beats stopping in place."""
    return "rtl" if "rtl" in (left, right) else left or right


class MissionState(TypedDict, total=False):
    params: dict[str, Any]
    outputs: Annotated[dict[str, Any], merge]  # step id -> what its action returned
    status: Annotated[dict[str, str], merge_status]  # ok | skipped | failed | blocked | scheduled | replaced ...
    errors: Annotated[dict[str, str], merge]
    attempts: Annotated[dict[str, int], merge]
    spliced: Annotated[dict[str, dict[str, Any]], merge]  # id -> {"step": ..., "deps": [...], "origin": ...}
    waits_for: Annotated[dict[str, list[str]], merge]  # step id -> replaced dependencies
    fired: Annotated[list[str], operator.add]
    events: Annotated[dict[str, Any], merge]  # trigger id -> the event it last fired for
    latched: Annotated[dict[str, Any], merge_latched]  # trigger id -> an event it was let act on, not yet fired
    approved: Annotated[dict[str, Any], merge]  # step id -> the arguments approved, kept over a pause (None: ask)
    reflections: int
    halt: Annotated[str | None, worst]
    preempted_by: str | None  # a trigger that took over: the rest of the plan is cancelled
    log: Annotated[list[dict[str, Any]], operator.add]


__all__ = ["FINISHED", "MissionState", "merge", "merge_latched", "merge_status", "worst"]
