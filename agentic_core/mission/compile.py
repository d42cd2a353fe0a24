"""Compiling a mission onto ``agentic_core.graph``.

* Every step of the plan is a node; ``depends_on`` are edges (joins for several dependencies), so steps with no
  dependency between them run in the same superstep. Steps nothing depends on lead to END.
* ``on_fail`` is a conditional edge from the step: ``trigger_reflection`` to ``__reflect__``, ``abort`` (and an
  exhausted ``retry``) to ``__abort__``, ``rtl`` to ``__rtl__``; ``skip`` lets dependents go on.
* ``__schedule__`` runs after every superstep in which a step finished: it fires triggers, and runs the steps
  that were spliced in (a trigger's sub-plan, a reflection's revised steps, a repeat's next iteration) as tasks
  of ``__dynamic__``, and steps that waited for them.
* ``__reflect__`` hands each failure (step, error, state) to the reflector, which may return revised steps; they
  are validated and replace the failed step, and its dependents wait for them instead. The default reflector
  gives up, and the mission aborts safely.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Annotated, Any, TypedDict

from pydantic import TypeAdapter, ValidationError

from ..graph import END, START, Command, CompiledStateGraph, Send, StateGraph
from ..graph.checkpoint import BaseCheckpointSaver
from .expressions import ExpressionError
from .model import PolicyGraph, RepeatStep, Step, Trigger
from .steps import Environment, StepFailed, run_iteration, run_with_retries, scope
from .validate import SCOPE_ROOTS

REFLECT, ABORT, RTL, SCHEDULE, DYNAMIC = "__reflect__", "__abort__", "__rtl__", "__schedule__", "__dynamic__"
DONE = frozenset({"ok", "skipped"})
FINISHED = frozenset({*DONE, "failed", "replaced", "preempted", "cancelled"})
STEPS_ADAPTER: TypeAdapter[list[Step]] = TypeAdapter(list[Step])


def merge(left: dict[str, Any], right: dict[str, Any]) -> dict[str, Any]:
    return {**left, **right}


def worst(left: str | None, right: str | None) -> str | None:
    """Two halts in one superstep: returning home beats stopping in place."""
    return "rtl" if "rtl" in (left, right) else left or right


class MissionState(TypedDict, total=False):
    params: dict[str, Any]
    outputs: Annotated[dict[str, Any], merge]  # step id -> what its action returned
    status: Annotated[dict[str, str], merge]  # step id -> ok | skipped | failed | blocked | scheduled | replaced ...
    errors: Annotated[dict[str, str], merge]
    attempts: Annotated[dict[str, int], merge]
    spliced: Annotated[dict[str, dict[str, Any]], merge]  # id -> {"step": ..., "deps": [...], "origin": ...}
    waits_for: Annotated[dict[str, list[str]], merge]  # step id -> replaced dependencies
    fired: Annotated[list[str], operator.add]
    reflections: int
    halt: Annotated[str | None, worst]
    preempted_by: str | None  # a trigger that took over: the rest of the plan is cancelled
    log: Annotated[list[dict[str, Any]], operator.add]


@dataclass
class Failure:
    """What a reflector is given: the step that failed, why, and the mission state at that moment."""

    step: Step
    error: str
    state: Mapping[str, Any]


Reflector = Callable[[Failure], list[Step] | list[dict[str, Any]] | None]


def abort_reflector(failure: Failure) -> None:
    """The default: no revision, so the mission aborts (the reasoning layer supplies a real reflector)."""
    return None


@dataclass
class MissionRuntime:
    """Everything the nodes of one compiled mission share."""

    plan: PolicyGraph
    env: Environment
    reflector: Reflector = abort_reflector
    max_reflections: int = 3
    static: dict[str, Step] = field(default_factory=dict)
    dependents: dict[str, list[str]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.static = {s.id: s for s in self.plan.steps}
        for step in self.plan.steps:
            for dep in self.deps(step.id, {}):
                self.dependents.setdefault(dep, []).append(step.id)

    def deps(self, step_id: str, state: Mapping[str, Any]) -> list[str]:
        replaced = (state.get("waits_for") or {}).get(step_id)
        if replaced is not None:
            return list(replaced)
        if step_id in self.static:
            return [*self.static[step_id].depends_on, *self.plan.dependencies.get(step_id, [])]
        return list((state.get("spliced") or {}).get(step_id, {}).get("deps", []))

    def step(self, step_id: str, state: Mapping[str, Any]) -> Step:
        if step_id in self.static:
            return self.static[step_id]
        return STEPS_ADAPTER.validate_python([state["spliced"][step_id]["step"]])[0]

    # --- running a step ---
    def execute(self, step_id: str, state: Mapping[str, Any]) -> dict[str, Any]:
        status = state.get("status") or {}
        if status.get(step_id) in FINISHED:
            return {}  # triggered again (by an edge and by the scheduler): it ran once, that is enough
        if state.get("halt") or not self.may_run(step_id, state):
            return {"status": {step_id: "cancelled"}}
        waiting = [d for d in self.deps(step_id, state) if status.get(d) not in DONE]
        if waiting:
            return {"status": {step_id: "blocked"}}
        step = self.step(step_id, state)
        if isinstance(step, RepeatStep):
            return self.iterate(step, state)
        try:
            output, attempts = run_with_retries(step, state, self.env)
        except StepFailed as failed:
            outcome = "skipped" if step.on_fail == "skip" else "failed"
            attempts = step.max_retries + 1
            return {
                "status": {step_id: outcome},
                "errors": {step_id: failed.reason},
                "attempts": {step_id: attempts},
                "log": [{"step": step_id, "status": outcome, "error": failed.reason}],
            }
        return {
            "status": {step_id: "ok"},
            "outputs": {step_id: output},
            "attempts": {step_id: attempts},
            "log": [{"step": step_id, "status": "ok", "attempts": attempts}],
        }

    def iterate(self, step: RepeatStep, state: Mapping[str, Any]) -> dict[str, Any]:
        done = int(((state.get("outputs") or {}).get(step.id) or {}).get("iterations", 0))
        try:
            output, finished = run_iteration(step, state, self.env, done)
        except StepFailed as failed:
            outcome = "skipped" if step.on_fail == "skip" else "failed"
            return {
                "status": {step.id: outcome},
                "errors": {step.id: failed.reason},
                "log": [{"step": step.id, "status": outcome, "error": failed.reason, "iteration": done + 1}],
            }
        return {
            "status": {step.id: "ok" if finished else "repeating"},
            "outputs": {step.id: output},
            "log": [{"step": step.id, "status": "ok", "iteration": done + 1, "finished": finished}],
        }

    def may_run(self, step_id: str, state: Mapping[str, Any]) -> bool:
        """Once a pre-empting trigger fired, only its own sub-plan (and what replaces its steps) runs."""
        owner = state.get("preempted_by")
        if not owner:
            return True
        info = (state.get("spliced") or {}).get(step_id)
        while info is not None and str(info.get("origin", "")).startswith("reflection:"):
            info = (state.get("spliced") or {}).get(str(info["origin"]).split(":", 1)[1])
        return info is not None and info.get("origin") == f"trigger:{owner}"

    def on_fail_route(self, step_id: str) -> Callable[[Mapping[str, Any]], str]:
        def route(state: Mapping[str, Any]) -> str:
            if (state.get("status") or {}).get(step_id) != "failed":
                return "next"
            policy = self.step(step_id, state).on_fail
            return {"trigger_reflection": REFLECT, "rtl": RTL}.get(policy, ABORT)

        route.__name__ = f"on_fail_{step_id}"
        return route

    # --- the scheduler ---
    def schedule(self, state: MissionState) -> Command[Any]:
        status = dict(state.get("status") or {})
        if state.get("halt"):
            return Command(goto=END)
        update: dict[str, Any] = {}
        spliced = dict(state.get("spliced") or {})
        preempted = state.get("preempted_by")
        for trigger in self.plan.triggers:
            event = None if preempted else self.fires(trigger, state)
            if event is None:
                continue
            new = self.splice(trigger.steps, origin=f"trigger:{trigger.id}", existing=spliced, event=event)
            spliced.update(new)
            update.setdefault("spliced", {}).update(new)
            update.setdefault("fired", []).append(trigger.id)
            update.setdefault("log", []).append({"step": trigger.id, "status": "fired", "event": event})
            if trigger.preempt:
                preempted = update["preempted_by"] = trigger.id
        if preempted:  # the main plan's unfinished steps, also those that wrote 'blocked' in the same superstep
            halted = {sid: "preempted" for sid in self.static if status.get(sid) in (None, "blocked", "repeating")}
            if halted:
                update.setdefault("status", {}).update(halted)
        goto: list[str | Send] = []
        marks: dict[str, str] = {}
        view: dict[str, Any] = {**state, "spliced": spliced, "preempted_by": preempted}
        for step_id in [*self.static, *spliced]:
            current = status.get(step_id)
            if not self.may_run(step_id, view):
                continue
            if not all(status.get(d) in DONE for d in self.deps(step_id, view)):
                continue
            if (step_id in spliced and current is None) or current in ("repeating", "blocked"):
                marks[step_id] = "scheduled"
                if step_id in spliced:
                    snapshot = {**view, "event": spliced[step_id].get("event")}
                    goto.append(Send(DYNAMIC, {"id": step_id, "state": snapshot}))
                else:
                    goto.append(step_id)
        for step_id, info in spliced.items():  # a spliced step that failed: its on_fail (static ones: their edge)
            if status.get(step_id) == "failed":
                policy = STEPS_ADAPTER.validate_python([info["step"]])[0].on_fail
                goto.append({"trigger_reflection": REFLECT, "rtl": RTL}.get(policy, ABORT))
        if marks:
            update.setdefault("status", {}).update(marks)
        return Command(update=update, goto=goto or END)

    def fires(self, trigger: Trigger, state: Mapping[str, Any]) -> Any:
        if trigger.once and trigger.id in (state.get("fired") or []):
            return None
        try:
            value = check_value(trigger.when, scope(state, self.env))
        except StepFailed:
            return None
        if not value:
            return None
        return value[0] if isinstance(value, list) else value

    def splice(
        self, steps: list[Step], *, origin: str, existing: Mapping[str, Any], event: Any = None
    ) -> dict[str, dict[str, Any]]:
        taken = {*self.static, *existing}
        clash = [s.id for s in steps if s.id in taken]
        if clash:
            raise StepFailed(f"revised steps reuse ids already in the mission: {', '.join(clash)}")
        ids = {s.id for s in steps}
        out = {}
        for s in steps:
            unknown = [d for d in s.depends_on if d not in ids]
            if unknown:
                raise StepFailed(f"revised step {s.id!r} depends on {unknown}, which are not among the revised steps")
            out[s.id] = {
                "step": s.model_dump(mode="json", by_alias=True),
                "deps": list(s.depends_on),
                "origin": origin,
                "event": event,
            }
        return out

    # --- policies ---
    def reflect(self, state: MissionState) -> Command[Any]:
        status = state.get("status") or {}
        count = int(state.get("reflections") or 0)
        update: dict[str, Any] = {"status": {}, "spliced": {}, "waits_for": {}, "log": []}
        spliced = dict(state.get("spliced") or {})
        for step_id, st in status.items():
            if st != "failed":
                continue
            step = self.step(step_id, state)
            if step.on_fail != "trigger_reflection":
                continue
            error = (state.get("errors") or {}).get(step_id, "")
            revised = self.reflector(Failure(step, error, state)) if count < self.max_reflections else None
            count += 1
            if not revised:
                update["log"].append({"step": step_id, "status": "reflection gave up", "error": error})
                return Command(update={**update, "reflections": count}, goto=ABORT)
            try:
                steps = STEPS_ADAPTER.validate_python(revised)
                new = self.splice(steps, origin=f"reflection:{step_id}", existing=spliced)
            except (ValidationError, StepFailed, ExpressionError) as exc:
                update["log"].append({"step": step_id, "status": "revision rejected", "error": str(exc)})
                return Command(update={**update, "reflections": count}, goto=ABORT)
            spliced.update(new)
            update["spliced"].update(new)
            update["status"][step_id] = "replaced"
            leaves = [s.id for s in steps if not any(s.id in o.depends_on for o in steps)]
            for dependent in self.dependents_of(step_id, spliced):
                others = [d for d in self.deps(dependent, state) if d != step_id]
                update["waits_for"][dependent] = [*others, *leaves]
            update["log"].append({"step": step_id, "status": "replaced", "by": [s.id for s in steps]})
        return Command(update={**update, "reflections": count}, goto=SCHEDULE)

    def dependents_of(self, step_id: str, spliced: Mapping[str, Any]) -> list[str]:
        found = list(self.dependents.get(step_id, []))
        found += [sid for sid, info in spliced.items() if step_id in info.get("deps", [])]
        return found

    def abort(self, state: MissionState) -> dict[str, Any]:
        failed = sorted(k for k, v in (state.get("status") or {}).items() if v == "failed")
        return {"halt": "abort", "log": [{"step": ABORT, "status": "aborted", "after": failed}]}

    def rtl(self, state: MissionState) -> dict[str, Any]:
        try:
            result = self.env.dispatch("flight.rtl", {}, None)
            entry = {"step": RTL, "status": result.status, "error": result.error}
        except Exception as exc:  # the last resort must not raise past the mission
            entry = {"step": RTL, "status": "error", "error": f"{type(exc).__name__}: {exc}"}
        return {"halt": "rtl", "log": [entry]}


def check_value(text: str, where: Mapping[str, Any]) -> Any:
    from .expressions import Expression

    try:
        return Expression.parse(text).evaluate(where)
    except ExpressionError as exc:
        raise StepFailed(str(exc)) from None


def compile_mission(
    plan: PolicyGraph,
    env: Environment,
    *,
    reflector: Reflector = abort_reflector,
    checkpointer: BaseCheckpointSaver | None = None,
    max_reflections: int = 3,
) -> CompiledStateGraph:
    """The mission as a runnable graph; invoke it with ``initial_state(plan, params)``."""
    rt = MissionRuntime(plan, env, reflector, max_reflections)
    g = StateGraph(MissionState)
    for step in plan.steps:
        g.add_node(step.id, _step_node(rt, step.id))
    g.add_node(DYNAMIC, lambda arg: rt.execute(arg["id"], arg["state"]))
    g.add_node(SCHEDULE, rt.schedule, destinations=(*rt.static, DYNAMIC, REFLECT, ABORT, RTL, END))
    g.add_node(REFLECT, rt.reflect, destinations=(SCHEDULE, ABORT))
    g.add_node(ABORT, rt.abort)
    g.add_node(RTL, rt.rtl)
    g.add_edge(ABORT, END)
    g.add_edge(RTL, END)
    g.add_edge(DYNAMIC, SCHEDULE)
    for step in plan.steps:
        deps = rt.deps(step.id, {})
        if not deps:
            g.add_edge(START, step.id)
        elif len(deps) == 1:
            g.add_edge(deps[0], step.id)
        else:
            g.add_edge(deps, step.id)
        g.add_edge(step.id, SCHEDULE)
        g.add_conditional_edges(
            step.id, rt.on_fail_route(step.id), {"next": END, REFLECT: REFLECT, ABORT: ABORT, RTL: RTL}
        )
    return g.compile(checkpointer=checkpointer)


def _step_node(rt: MissionRuntime, step_id: str) -> Callable[[MissionState], dict[str, Any]]:
    def node(state: MissionState) -> dict[str, Any]:
        return rt.execute(step_id, state)

    node.__name__ = step_id
    return node


def parse_param(plan: PolicyGraph, name: str, text: Any) -> Any:
    """A parameter value from the command line (text) or from code, checked against its declaration."""
    spec = plan.params.get(name)
    if spec is None:
        known = ", ".join(plan.params) or "none"
        raise ValueError(f"unknown parameter {name!r}; the mission has: {known}")
    value = text
    try:
        if spec.type == "number":
            value = float(text)
        elif spec.type == "integer":
            value = int(text)
        elif spec.type == "boolean":
            value = text if isinstance(text, bool) else str(text).strip().lower() in ("1", "true", "yes", "on")
        elif spec.type == "position" and isinstance(text, str):
            lat, lon = (float(v) for v in text.split(","))
            value = {"lat": lat, "lon": lon}
    except (TypeError, ValueError):
        article = "an" if spec.type[0] in "aeiou" else "a"
        raise ValueError(f"parameter {name!r} is {article} {spec.type}, not {text!r}") from None
    problem = spec.out_of_bounds(value)
    if problem:
        raise ValueError(f"parameter {name!r} {problem}")
    return value


def initial_state(plan: PolicyGraph, overrides: Mapping[str, Any] | None = None) -> MissionState:
    """The state a mission starts from: parameter defaults, overridden (and type-checked) by ``overrides``."""
    params = {name: p.default for name, p in plan.params.items()}
    for name, value in (overrides or {}).items():
        params[name] = parse_param(plan, name, value)
    return {"params": params, "outputs": {}, "status": {}, "fired": [], "log": [], "reflections": 0}


def layers(plan: PolicyGraph) -> list[list[str]]:
    """The plan's steps grouped by the superstep they run in when nothing fails (topological generations)."""
    import networkx as nx

    graph = nx.DiGraph()
    for step in plan.steps:
        graph.add_node(step.id)
        for dep in [*step.depends_on, *plan.dependencies.get(step.id, [])]:
            graph.add_edge(dep, step.id)
    return [sorted(gen) for gen in nx.topological_generations(graph)]


__all__ = [
    "SCOPE_ROOTS",
    "Environment",
    "Failure",
    "MissionState",
    "compile_mission",
    "initial_state",
    "layers",
    "parse_param",
]
