"""Tier 1: what a trigger's rule finds, the one evaluation used at the scheduler's barriers and by the agent while
a long flight action flies.

A trigger may fire when it has not fired yet, or (``once: false``) when the sub-plan of its last firing has
finished, and then only for an event other than the last one it fired for.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from .functions import MISSING, get_field
from .model import Trigger
from .state import FINISHED
from .steps import Environment, StepFailed, evaluate, scope


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
    last = identity((state.get("events") or {}).get(trigger.id))
    return [e for e in events if identity(e) != last]


__all__ = ["identity", "may_fire", "object_id", "trigger_events"]
