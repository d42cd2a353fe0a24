"""PolicyGraph, the mission contract (the paper's name): one pydantic model, its JSON Schema exported from it.

A mission is what users write in YAML and what the LLM planner emits as JSON: ``plan_id``, ``goal``, typed
``params``, ``limits``, ``steps`` and ``triggers``. Each step's ``action`` selects its own ``args`` model, so the
JSON Schema tells an editor exactly which arguments an action takes. Wherever a value is expected, a
``${...}`` expression may stand instead; it is checked at load time and evaluated when the step runs.

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
import typing
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StringConstraints, model_validator

from . import flight_args
from .swarm_plan import SwarmPlan, uav_problems

TEMPLATE_PATTERN = r"^\$\{.+\}$"
Template = Annotated[str, StringConstraints(pattern=TEMPLATE_PATTERN)]
"""A value computed when the step runs: ``"${params.altitude_m + 10}"``."""

Number = flight_args.Number | Template
Positive = flight_args.Positive | Template
NonNegative = flight_args.NonNegative | Template
Latitude = flight_args.Latitude | Template
Longitude = flight_args.Longitude | Template
StepId = Annotated[str, StringConstraints(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", max_length=64)]
OnFail = Literal["trigger_reflection", "retry", "skip", "abort", "rtl"]
MAX_STEPS = 1000
"""The most steps a mission may have, nested and trigger steps included: real missions have tens, and checking
one grows with their number."""
NESTED_STEP_LISTS = ("steps", "then", "else")
"""The keys of a step (a repeat's, a branch's) that hold steps, as written."""


class Contract(BaseModel):
    """Base of every mission model: unknown fields are errors, not silently ignored."""

    model_config = ConfigDict(extra="forbid", strict=True)  # "30" is not a number here: as in the JSON Schema


# The flight actions' arguments are flight_args' models with ${...} templates allowed; no docstrings where the
# plain model has none (a docstring is part of the JSON Schema).
class LatLon(flight_args.LatLonOf[Template], Contract):
    pass


class Circle(Contract):
    center: LatLon
    radius_m: float = Field(gt=0)


FailsafeAction = Literal["rtl", "land", "hold"]
FailsafeKind = Literal["battery", "link", "wind", "gps", "flight_time"]
"""The failsafes evaluated on telemetry (:mod:`agentic_core.agent.failsafes`)."""
GPS_LANDS: dict[FailsafeKind, FailsafeAction] = {"gps": "land"}


class Limits(Contract):
    """Safety limits every step is checked against at load time and by the flight envelope when it flies."""

    geofence: Annotated[list[LatLon], Field(min_length=3)] | Circle | None = Field(
        default=None, description="a polygon of at least three points, or a circle"
    )
    max_altitude_m: float | None = Field(default=None, gt=0, description="above the home position")
    min_battery_pct: float | None = Field(default=None, ge=0, le=100)
    max_wind_mps: float | None = Field(default=None, gt=0)
    max_flight_time_s: float | None = Field(
        default=None, gt=0, description="the mission's time limit: seconds of the vehicle's clock since take-off"
    )
    link_loss_s: float = Field(
        default=10.0, gt=0, description="no telemetry for this long in the air is a lost link (PX4's COM_DL_LOSS_T)"
    )
    failsafe_action: FailsafeAction = Field(
        default="rtl", description="what a failsafe on telemetry does: return to launch, land or hold where it is"
    )
    failsafe_actions: dict[FailsafeKind, FailsafeAction] = Field(
        default_factory=lambda: dict(GPS_LANDS),
        description="a failsafe's own action, over failsafe_action (GPS loss lands unless told otherwise: a "
        "return needs a position)",
    )


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


# --- arguments of each action ---
class TakeoffArgs(flight_args.TakeoffArgsOf[Template], Contract):
    pass


class FlyToArgs(flight_args.FlyToArgsOf[Template], Contract):
    """Exactly one way of saying where: ``lat``/``lon``, local ``north_m``/``east_m``, or a world-model object."""


class SurveyArgs(Contract):
    polygon: Annotated[list[LatLon], Field(min_length=3)] | Template = Field(description="the area, 3+ points")
    altitude_m: Positive
    spacing_m: Annotated[float, Field(ge=1, allow_inf_nan=False)] | Template = Field(
        default=20.0, description="distance between the lawnmower lines, at least 1 m"
    )
    speed_mps: Positive | None = None


class OrbitArgs(flight_args.OrbitArgsOf[Template, LatLon], Contract):
    pass


class HoverArgs(flight_args.HoverArgsOf[Template], Contract):
    pass


class LandArgs(flight_args.LandArgsOf[Template], Contract):
    """Land here (no arguments), at a position, or beside a world-model object (``offset_m`` away from it)."""


class NoArgs(flight_args.NoArgs, Contract):
    pass


class DeployPayloadArgs(flight_args.DeployPayloadArgs, Contract):
    pass


class AnalyzeSceneArgs(Contract):
    focus: str | None = Field(default=None, description="an object id, or a description of what to look at")
    min_confidence: Annotated[float, Field(ge=0, le=1)] | Template = 0.5


class NotifyArgs(Contract):
    channel: Literal["email", "webhook", "log"] = "email"
    to: list[str] | str | None = None
    subject: str
    body: str
    attach: list[str] = Field(default_factory=list, description="e.g. snapshot, position, world_model")


# --- steps ---
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


def walk_steps(steps: list[Any]) -> list[StepBase]:
    """Every step of ``steps``, those nested in repeats and branches included, in document order."""
    found: list[StepBase] = []
    for step in steps:
        found.append(step)
        for nested in ("steps", "then", "else_"):
            found += walk_steps(getattr(step, nested, None) or [])
    return found


ON_ABORT_TOOLS: dict[str, str] = {"rtl": "flight.rtl", "land": "flight.land", "hold": "flight.hold"}
"""The flight tool that carries out each ``on_abort``."""


def step_args(step: StepBase) -> dict[str, Any]:
    """A step's arguments as plain data (templates still in place); control steps have none."""
    args = getattr(step, "args", None)
    if isinstance(args, BaseModel):
        return args.model_dump(by_alias=True, exclude_none=True)
    return dict(args or {})


def mission_json_schema() -> dict[str, Any]:
    """The JSON Schema of mission files, generated from :class:`PolicyGraph`."""
    schema = PolicyGraph.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "agentic-uavs mission (PolicyGraph)"
    return schema


for _model in (RepeatStep, BranchStep, Trigger, PolicyGraph):
    _model.model_rebuild()


__all__ = [
    "ACTIONS",
    "ACTION_TOOLS",
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
