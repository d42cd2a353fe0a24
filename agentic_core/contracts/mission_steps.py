"""A mission's steps: one model per action (:data:`Step`, discriminated by ``action``), repeats and branches nesting
steps, the tool each action calls, and walking nested steps.

>>> from agentic_core.contracts.mission_steps import RepeatStep, walk_steps
>>> patrol = RepeatStep.model_validate({"id": "patrol", "action": "repeat", "until": "false",
...     "steps": [{"id": "look", "action": "hover", "args": {"duration_s": 5}}]})
>>> [s.id for s in walk_steps([patrol])]
['patrol', 'look']
"""

from __future__ import annotations

import typing
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field, StringConstraints

from .action_args import (
    AnalyzeSceneArgs,
    DeployPayloadArgs,
    FlyToArgs,
    HoverArgs,
    LandArgs,
    NoArgs,
    NotifyArgs,
    OrbitArgs,
    SurveyArgs,
    TakeoffArgs,
)
from .mission_values import Contract

StepId = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]
OnFail = Literal["trigger_reflection", "retry", "skip", "abort", "rtl"]
NESTED_STEP_LISTS = ("steps", "then", "else")
"""The keys of a step (a repeat's, a branch's) that hold steps, as written."""


class StepBase(Contract):
    id: StepId
    description: str = ""
    depends_on: list[StepId] = Field(default_factory=list)
    preconditions: list[str] = Field(default_factory=list, description="expressions that must all be true")
    on_fail: OnFail = "abort"
    max_retries: int = Field(default=0, ge=0, le=20, description="retries before on_fail applies")
    timeout_s: float | None = Field(default=None, gt=0)
    approval: bool = Field(default=False, description="an operator must approve before the step runs")
    uav: str | None = Field(
        default=None,
        description="a swarm mission's UAVs that have this step: a role of swarm.roles, or 'any' (the swarm awards "
        "it at run time); default: every UAV, or the one drone",
    )


class TakeoffStep(StepBase):
    action: Literal["takeoff"]
    args: TakeoffArgs = Field(default_factory=TakeoffArgs)


class FlyToStep(StepBase):
    action: Literal["fly_to"]
    args: FlyToArgs


class SurveyStep(StepBase):
    action: Literal["survey"]
    args: SurveyArgs


class OrbitStep(StepBase):
    action: Literal["orbit"]
    args: OrbitArgs


class HoverStep(StepBase):
    action: Literal["hover"]
    args: HoverArgs


class LandStep(StepBase):
    action: Literal["land"]
    args: LandArgs = Field(default_factory=LandArgs)


class RtlStep(StepBase):
    action: Literal["rtl"]
    args: NoArgs = Field(default_factory=NoArgs)


class DeployPayloadStep(StepBase):
    action: Literal["deploy_payload"]
    args: DeployPayloadArgs = Field(default_factory=DeployPayloadArgs)


class CallToolStep(StepBase):
    """Any registered tool; its arguments are checked against the tool's own schema."""

    action: Literal["call_tool"]
    tool: str = Field(
        pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)+$", description="e.g. weather.get_forecast"
    )
    args: dict[str, Any] = Field(default_factory=dict)


class AnalyzeSceneStep(StepBase):
    action: Literal["analyze_scene"]
    args: AnalyzeSceneArgs = Field(default_factory=AnalyzeSceneArgs)


class NotifyStep(StepBase):
    action: Literal["notify"]
    args: NotifyArgs


class WaitUntilStep(StepBase):
    action: Literal["wait_until"]
    condition: str
    poll_s: float = Field(default=1.0, gt=0)


class RepeatStep(StepBase):
    """Run ``steps`` in order, again and again, until ``until`` is true (a patrol)."""

    action: Literal["repeat"]
    steps: list[Step] = Field(min_length=1)
    until: str
    max_iterations: int = Field(default=100, ge=1)


class BranchStep(StepBase):
    """Run ``then`` if the condition holds, else ``else``."""

    action: Literal["branch"]
    if_: str = Field(alias="if")
    then: list[Step] = Field(min_length=1)
    else_: list[Step] = Field(default_factory=list, alias="else")


Step = Annotated[
    TakeoffStep
    | FlyToStep
    | SurveyStep
    | OrbitStep
    | HoverStep
    | LandStep
    | RtlStep
    | DeployPayloadStep
    | CallToolStep
    | AnalyzeSceneStep
    | NotifyStep
    | WaitUntilStep
    | RepeatStep
    | BranchStep,
    Field(discriminator="action"),
]
STEP_MODELS: dict[str, type[StepBase]] = {
    typing.get_args(model.model_fields["action"].annotation)[0]: model
    for model in typing.get_args(typing.get_args(Step)[0])
}
"""The step model of each action."""
ACTIONS: tuple[str, ...] = (
    "takeoff",
    "fly_to",
    "survey",
    "orbit",
    "hover",
    "land",
    "rtl",
    "deploy_payload",
    "call_tool",
    "analyze_scene",
    "notify",
    "wait_until",
    "repeat",
    "branch",
)
ACTION_TOOLS: dict[str, str] = {
    "takeoff": "flight.takeoff",
    "fly_to": "flight.fly_to",
    "survey": "flight.fly_to",  # a survey flies its lawnmower legs one fly_to at a time
    "orbit": "flight.orbit",
    "hover": "flight.hover",
    "land": "flight.land",
    "rtl": "flight.rtl",
    "deploy_payload": "flight.deploy_payload",
    "analyze_scene": "perception.analyze_scene",
    "notify": "alerts.notify",
}
"""The registered tool each action calls; ``call_tool`` names its own, the control actions call none."""


def walk_steps(steps: list[Any]) -> list[StepBase]:
    """Every step of ``steps``, those nested in repeats and branches included, in document order."""
    found: list[StepBase] = []
    for step in steps:
        found.append(step)
        for nested in ("steps", "then", "else_"):
            found += walk_steps(getattr(step, nested, None) or [])
    return found


def step_args(step: StepBase) -> dict[str, Any]:
    """A step's arguments as plain data (templates still in place); control steps have none."""
    args = getattr(step, "args", None)
    if isinstance(args, BaseModel):
        return args.model_dump(by_alias=True, exclude_none=True)
    return dict(args or {})


for _model in (RepeatStep, BranchStep):
    _model.model_rebuild()


__all__ = [
    "ACTIONS",
    "ACTION_TOOLS",
    "NESTED_STEP_LISTS",
    "STEP_MODELS",
    "AnalyzeSceneStep",
    "BranchStep",
    "CallToolStep",
    "DeployPayloadStep",
    "FlyToStep",
    "HoverStep",
    "LandStep",
    "NotifyStep",
    "OnFail",
    "OrbitStep",
    "RepeatStep",
    "RtlStep",
    "Step",
    "StepBase",
    "StepId",
    "SurveyStep",
    "TakeoffStep",
    "WaitUntilStep",
    "step_args",
    "walk_steps",
]
