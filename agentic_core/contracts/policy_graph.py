"""PolicyGraph, the mission contract (the paper's name): one pydantic model, its JSON Schema exported from it.

A mission is what users write in YAML and what the LLM planner emits as JSON: ``plan_id``, ``goal``, typed
``params``, ``limits``, ``steps`` and ``triggers``. Each step's ``action`` selects its own ``args`` model, so the
JSON Schema tells an editor exactly which arguments an action takes. Wherever a value is expected, a
``${...}`` expression may stand instead; it is checked at load time and evaluated when the step runs.

The mission itself, its parameters and triggers are defined here; its parts each in their own module, every name
importable from here too: the steps in :mod:`~agentic_core.contracts.mission_steps`, their arguments in
:mod:`~agentic_core.contracts.action_args`, the limits in :mod:`~agentic_core.contracts.mission_limits`, templates,
positions and the strict base in :mod:`~agentic_core.contracts.mission_values`.

>>> from agentic_core.contracts.policy_graph import PolicyGraph
>>> plan = PolicyGraph.model_validate({
...     "plan_id": "P-1", "goal": "look around",
...     "steps": [{"id": "up", "action": "takeoff", "args": {"altitude_m": 20}},
...               {"id": "look", "action": "hover", "args": {"duration_s": 5}, "depends_on": ["up"]}]})
>>> [s.id for s in plan.steps]
['up', 'look']
"""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import Field, StringConstraints, model_validator

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
from .mission_limits import GPS_LANDS, FailsafeAction, FailsafeKind, Limits
from .mission_steps import (
    ACTION_TOOLS,
    ACTIONS,
    NESTED_STEP_LISTS,
    STEP_MODELS,
    AnalyzeSceneStep,
    BranchStep,
    CallToolStep,
    DeployPayloadStep,
    FlyToStep,
    HoverStep,
    LandStep,
    NotifyStep,
    OnFail,
    OrbitStep,
    RepeatStep,
    RtlStep,
    Step,
    StepBase,
    StepId,
    SurveyStep,
    TakeoffStep,
    WaitUntilStep,
    step_args,
    walk_steps,
)
from .mission_values import (
    MAX_POINTS,
    TEMPLATE_PATTERN,
    Circle,
    Contract,
    Latitude,
    LatLon,
    Longitude,
    NonNegative,
    Number,
    Positive,
    Template,
)
from .swarm_plan import SwarmPlan, uav_problems

MAX_STEPS = 1000
"""The most steps a mission may have, nested and trigger steps included: real missions have tens, and checking
one grows with their number."""


class Param(Contract):
    """A mission parameter: typed, with a default, overridable from the command line (``--param name=value``)."""

    type: Literal["number", "integer", "string", "boolean", "position"] = "number"
    default: Any = None
    description: str = ""
    minimum: float | None = None
    maximum: float | None = None

    @model_validator(mode="after")
    def _default_fits(self) -> Param:
        value = self.default
        if value is None:
            return self
        fits = {
            "number": isinstance(value, int | float) and not isinstance(value, bool),
            "integer": isinstance(value, int) and not isinstance(value, bool),
            "string": isinstance(value, str),
            "boolean": isinstance(value, bool),
            "position": isinstance(value, dict) and {"lat", "lon"} <= set(value),
        }[self.type]
        if not fits:
            raise ValueError(f"default {value!r} is not a {self.type}")
        problem = self.out_of_bounds(value)
        if problem:
            raise ValueError(f"the default {problem}")
        return self

    def out_of_bounds(self, value: Any) -> str | None:
        """Why a number breaks this parameter's minimum or maximum (or is not finite), or None."""
        if isinstance(value, int | float) and not isinstance(value, bool):
            shown = f"{value:g}" if isinstance(value, float) else str(value) if abs(value) < 10**20 else "a huge number"
            if isinstance(value, float) and not math.isfinite(value):
                return f"must be a finite number, got {value}"
            if self.minimum is not None and value < self.minimum:
                return f"must be at least {self.minimum:g}, got {shown}"
            if self.maximum is not None and value > self.maximum:
                return f"must be at most {self.maximum:g}, got {shown}"
        return None


class Trigger(Contract):
    """An event over the world model that starts a sub-plan, e.g. a person motionless and isolated."""

    id: StepId
    when: str = Field(description="an expression over world, vehicle, params and step outputs")
    steps: list[Step] = Field(min_length=1)
    once: bool = Field(default=True, description="fire at most once per mission")
    preempt: bool = Field(default=True, description="stop the rest of the plan (a patrol) while the sub-plan runs")
    plan: Literal["steps", "reasoner"] = Field(
        default="steps",
        description="who writes the response: 'steps' runs the steps above; 'reasoner' asks the reasoner for a "
        "plan (checked like the mission itself), the steps above running when it proposes none or is refused",
    )
    uav: str | None = Field(
        default=None,
        description="a swarm mission's UAVs that watch for this: a role of swarm.roles, or 'any' (whichever sees it "
        "first responds for the fleet); default: every UAV, or the one drone",
    )


OnAbort = Literal["rtl", "land", "hold"]


class PolicyGraph(Contract):
    """A mission: the plan the Action Layer executes (paper §3, Reasoning Layer output)."""

    plan_id: str = Field(min_length=1)
    goal: str = Field(min_length=1)
    params: dict[StepId, Param] = Field(default_factory=dict)
    limits: Limits = Field(default_factory=Limits)
    steps: list[Step] = Field(min_length=1)
    triggers: list[Trigger] = Field(default_factory=list)
    dependencies: dict[str, list[str]] = Field(
        default_factory=dict, description="the paper's form of depends_on: {step_id: [step_id, ...]}"
    )
    on_abort: OnAbort = Field(
        default="rtl",
        description="what the aircraft does when the mission aborts (a failed step's abort, or the operator's): "
        "return to launch (rtl), land where it is (land), or hold where it is (hold)",
    )
    scopes: list[Annotated[str, StringConstraints(pattern=r"^[a-z_*][a-z0-9_]*:[a-z_*][a-z0-9_]*$")]] | None = Field(
        default=None,
        description="the scopes the agent holds for this mission (e.g. flight:command, alerts:send); default: those "
        "its steps' and triggers' tools need, and nothing more",
    )
    knowledge: list[Annotated[str, StringConstraints(min_length=1, max_length=200)]] = Field(
        default_factory=list,
        max_length=10,
        description="topics to look up in the knowledge documents ingested into the run's memory (agentic-uav memory "
        "ingest; the run needs --memory): the passages found reach the model's assessment prompt as untrusted data",
    )
    allow_tools: list[
        Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)+$")]
    ] = Field(
        default_factory=list,
        description="tools a model's plan or revision may call besides those the mission's own steps use",
    )
    swarm: SwarmPlan | None = Field(
        default=None, description="flown by several UAVs (agentic-uav swarm run): sectors, roles, layers, k-of-n"
    )

    @model_validator(mode="after")
    def _uav_names(self) -> PolicyGraph:
        steps = walk_steps(self.steps) + [s for t in self.triggers for s in walk_steps(t.steps)]
        if len(steps) > MAX_STEPS:
            raise ValueError(
                f"a mission has at most {MAX_STEPS:,} steps, nested and trigger steps included; this one has "
                f"{len(steps):,}"
            )
        named = [s.uav for s in steps] + [t.uav for t in self.triggers]
        problems = uav_problems((n for n in named if n is not None), self.swarm)
        if problems:
            raise ValueError("; ".join(problems))
        return self


ON_ABORT_TOOLS: dict[str, str] = {"rtl": "flight.rtl", "land": "flight.land", "hold": "flight.hold"}
"""The flight tool that carries out each ``on_abort``."""


def mission_json_schema() -> dict[str, Any]:
    """The JSON Schema of mission files, generated from :class:`PolicyGraph`."""
    schema = PolicyGraph.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "agentic-uavs mission (PolicyGraph)"
    return schema


for _model in (Trigger, PolicyGraph):
    _model.model_rebuild()


__all__ = [
    "ACTIONS",
    "ACTION_TOOLS",
    "GPS_LANDS",
    "MAX_POINTS",
    "MAX_STEPS",
    "NESTED_STEP_LISTS",
    "ON_ABORT_TOOLS",
    "STEP_MODELS",
    "TEMPLATE_PATTERN",
    "AnalyzeSceneArgs",
    "AnalyzeSceneStep",
    "BranchStep",
    "CallToolStep",
    "Circle",
    "Contract",
    "DeployPayloadArgs",
    "DeployPayloadStep",
    "FailsafeAction",
    "FailsafeKind",
    "FlyToArgs",
    "FlyToStep",
    "HoverArgs",
    "HoverStep",
    "LandArgs",
    "LandStep",
    "LatLon",
    "Latitude",
    "Limits",
    "Longitude",
    "NoArgs",
    "NonNegative",
    "NotifyArgs",
    "NotifyStep",
    "Number",
    "OnAbort",
    "OnFail",
    "OrbitArgs",
    "OrbitStep",
    "Param",
    "PolicyGraph",
    "Positive",
    "RepeatStep",
    "RtlStep",
    "Step",
    "StepBase",
    "StepId",
    "SurveyArgs",
    "SurveyStep",
    "TakeoffArgs",
    "TakeoffStep",
    "Template",
    "Trigger",
    "WaitUntilStep",
    "mission_json_schema",
    "step_args",
    "walk_steps",
]
