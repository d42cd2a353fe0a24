"""The Plan contract (class ``Proposal``): the steps a reasoner proposes in answer to an event or a failure, in
the mission language.

A proposal is only words until the mission validator has passed it: the steps are the same ``Step`` models a
mission file holds, so the same checks (actions, tools, geofence, altitude) apply to a model's plan as to a
person's.

>>> proposal = Proposal.model_validate({"steps": [{"id": "hold_here", "action": "hover", "args": {"duration_s": 5}}],
...                                     "rationale": "wait for the crowd to clear"})
>>> [s.action for s in proposal.steps]
['hover']
"""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from .mission_steps import Step


class Proposal(BaseModel):
    """Steps to splice into the running mission (empty: nothing to do, or give up), and why."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    steps: list[Step] = Field(default_factory=list, description="mission steps, in the mission file's format")
    rationale: str = Field(default="", description="why these steps")


Plan = Proposal
"""The contract's name in the architecture."""


def proposal_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`Proposal` (the structured output the planning and reflection prompts ask for)."""
    return Proposal.model_json_schema(by_alias=True)


__all__ = ["Plan", "Proposal", "proposal_json_schema"]
