"""What a reflector is given when a mission step fails: the step, why, and the mission state at that moment.

The mission's compiler builds it and the reasoning layer's reflectors read it, so it lives in the contracts, which
both may import.

>>> from agentic_core.contracts.policy_graph import PolicyGraph
>>> plan = {"plan_id": "p", "goal": "g", "steps": [{"id": "up", "action": "takeoff"}]}
>>> step = PolicyGraph.model_validate(plan).steps[0]
>>> Failure(step=step, error="timed out", state={"rounds": 1}).step.id
'up'
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from .mission_steps import Step


@dataclass
class Failure:
    """What a reflector is given: the step that failed, why, and the mission state at that moment."""

    step: Step
    error: str
    state: Mapping[str, Any]


__all__ = ["Failure"]
