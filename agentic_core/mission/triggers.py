"""Tier 1: what a trigger's rule finds, the one evaluation used at the scheduler's barriers and by the agent while
a long flight action flies.

A trigger may fire when it has not fired yet, or (``once: false``) when the sub-plan of its last firing has
finished, and then only for an event other than the last one it fired for. An object of the same class within
:data:`REID_M` of where that one was, while that one's track is gone, is the same one under a new track id (the
casualty a patrol comes back over), so a response that did not help is not started again and again.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .functions import MISSING, get_field
from .model import Trigger
from .state import FINISHED
from .steps import Environment, StepFailed, evaluate, scope

REID_M = 8.0
"""How near (m) an object must be to where a trigger's last object was, that object's track gone, to be it."""


def identity(event: Any) -> Any:
    """What makes two events the same: a world-model object's id (its pose and timers change every frame)."""
    found = get_field(event, "id")
    return event if found is MISSING else found


def object_id(event: Any) -> str | None:
    """The world-model object an event is (None for an event that is not an object)."""
    found = get_field(event, "id")
    return None if found is MISSING else str(found)


def may_fire(trigger: Trigger, state: Mapping[str, Any]) -> bool:
    """Whether ``trigger`` may fire at all now (not spent, its last sub-plan not running)."""
    fired = trigger.id in (state.get("fired") or [])
    if fired and trigger.once:
        return False
    if fired:
        status = state.get("status") or {}
        origin = f"trigger:{trigger.id}"
        running = [s for s, i in (state.get("spliced") or {}).items() if i.get("origin") == origin]
        if any(status.get(s) not in FINISHED for s in running):
            return False
    return True


def trigger_events(trigger: Trigger, state: Mapping[str, Any], env: Environment) -> list[Any]:
    """The events ``trigger``'s rule finds now that it may fire for (empty when it may not fire, when the rule is
    false, or when it cannot be evaluated yet)."""
    if not may_fire(trigger, state):
        return []
    try:
        value = evaluate(trigger.when, scope(state, env))
    except StepFailed:
        return []
    if not value:
        return []
    events = value if isinstance(value, list) else [value]
    if trigger.id not in (state.get("fired") or []):
        return events
    last = (state.get("events") or {}).get(trigger.id)
    tracked = {identity(o) for o in _objects(env.world()) if get_field(o, "state") != "lost"}
    return [e for e in events if not same_event(e, last, tracked)]


def _objects(world: Any) -> list[Any]:
    found = get_field(world, "objects")
    return [] if found is MISSING or not isinstance(found, list) else found


def _north_east(event: Any) -> tuple[float, float] | None:
    pose = get_field(event, "pose")
    north, east = (MISSING, MISSING) if pose is MISSING else (get_field(pose, "north"), get_field(pose, "east"))
    return (float(north), float(east)) if isinstance(north, int | float) and isinstance(east, int | float) else None


def same_event(event: Any, last: Any, tracked: set[Any]) -> bool:
    """Whether ``event`` is ``last`` again: the same identity, or (``last``'s object no longer among ``tracked``)
    an object of its class within :data:`REID_M` of where it was.

    >>> was = {"id": "P-1", "class": "person", "pose": {"north": 40.0, "east": 5.0}}
    >>> again = {"id": "P-9", "class": "person", "pose": {"north": 42.0, "east": 6.0}}
    >>> same_event(again, was, tracked={"P-9"}), same_event(again, was, tracked={"P-1", "P-9"})
    (True, False)
    """
    if identity(event) == identity(last):
        return True
    if object_id(last) is None or identity(last) in tracked or get_field(event, "class") != get_field(last, "class"):
        return False
    here, there = _north_east(event), _north_east(last)
    return here is not None and there is not None and math.dist(here, there) <= REID_M


__all__ = ["REID_M", "identity", "may_fire", "object_id", "same_event", "trigger_events"]
