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

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from pydantic import TypeAdapter, ValidationError

from ..contracts.failure import Failure
from ..graph import END, START, Command, CompiledStateGraph, Send, StateGraph
from ..graph.checkpoint import BaseCheckpointSaver
from .expressions import ExpressionError
from .grounded import ground_tool
from .model import ON_ABORT_TOOLS, PolicyGraph, RepeatStep, Step, Trigger
from .state import FINISHED, MissionState
from .steps import (
    ALIASES,
    Environment,
    Interrupted,
    StepFailed,
    StepInterrupted,
    keep_approval,
    run_iteration,
    run_with_retries,
    step_call,
)
from .tool_check import ToolCatalog
from .triggers import identity, may_fire, trigger_events
from .validate import check_revision, iter_steps

REFLECT, ABORT, RTL, SCHEDULE, DYNAMIC = "__reflect__", "__abort__", "__rtl__", "__schedule__", "__dynamic__"
DONE = frozenset({"ok", "skipped"})
STEPS_ADAPTER: TypeAdapter[list[Step]] = TypeAdapter(list[Step])


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
    tools: ToolCatalog | None = None  # a revision's call_tool steps are checked against it
    static: dict[str, Step] = field(default_factory=dict)
    document_ids: set[str] = field(default_factory=set)
    dependents: dict[str, list[str]] = field(default_factory=dict)
    verdicts: dict[tuple[str, Any], bool] = field(default_factory=dict)  # (trigger, event id) -> the gate's say
    declined: list[dict[str, Any]] = field(default_factory=list)  # gate refusals not yet logged

    def __post_init__(self) -> None:
        self.static = {s.id: s for s in self.plan.steps}
        self.document_ids = {site.step.id for site in iter_steps(self.plan)} | {t.id for t in self.plan.triggers}
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
        if state.get("halt"):
            return {"status": {step_id: "cancelled"}}
        if not self.may_run(step_id, state):
            return {"status": {step_id: "blocked"}}  # paused while a trigger's sub-plan runs
        started_by_an_edge = step_id in self.static and self.deps(step_id, state)
        if started_by_an_edge and not state.get("preempted_by") and self.preempting(state):
            return {"status": {step_id: "blocked"}}  # a trigger fires as it starts: the scheduler decides
        waiting = [d for d in self.deps(step_id, state) if status.get(d) not in DONE]
        if waiting:
            return {"status": {step_id: "blocked"}}
        step = self.step(step_id, state)
        origin = (state.get("spliced") or {}).get(step_id, {}).get("origin")
        try:
            with step_call(step_id, origin, state):
                if isinstance(step, RepeatStep):
                    return self.iterate(step, state)
                output, attempts = run_with_retries(step, state, self.env)
        except StepFailed as failed:
            return {**self.failure(step, failed.reason), "attempts": {step_id: step.max_retries + 1}}
        except StepInterrupted as stopped:
            status = "repeating" if isinstance(step, RepeatStep) else "blocked"
            kept = (state.get("approved") or {}).get(step_id) is not None
            return self.interrupted(step, stopped.outcome, status, stopped.approved, kept_before=kept)
        return {
            "status": {step_id: "ok"},
            "outputs": {step_id: output},
            "attempts": {step_id: attempts},
            "log": [{"step": step_id, "status": "ok", "attempts": attempts}],
        }

    def interrupted(
        self,
        step: Step,
        outcome: Interrupted,
        status: str,
        approved: dict[str, Any] | None = None,
        *,
        kept_before: bool = False,
    ) -> dict[str, Any]:
        """A step whose action was stopped before its end runs again once the scheduler lets it (a repeat starts its
        pass again); a trigger that stopped it stays latched on its event until it fires. The operator's approval
        of it is kept over a pause; a trigger that took over changed the situation, so it is asked again."""
        entry = {"step": step.id, "status": "interrupted", "error": outcome.reason, "trigger": outcome.trigger}
        update: dict[str, Any] = {"status": {step.id: status}, "log": [entry]}
        if outcome.trigger is not None:
            update["latched"] = {outcome.trigger: outcome.event}
            if kept_before:
                update["approved"] = {step.id: None}  # the approval kept over an earlier pause no longer holds
        elif approved is not None:
            update["approved"] = {step.id: keep_approval(approved, self.env)}
            entry["approval"] = "kept"
        return update

    def iterate(self, step: RepeatStep, state: Mapping[str, Any]) -> dict[str, Any]:
        done = int(((state.get("outputs") or {}).get(step.id) or {}).get("iterations", 0))
        try:
            output, finished = run_iteration(step, state, self.env, done)
        except StepFailed as failed:
            return self.failure(step, failed.reason, iteration=done + 1)
        return {
            "status": {step.id: "ok" if finished else "repeating"},
            "outputs": {step.id: output},
            "log": [{"step": step.id, "status": "ok", "iteration": done + 1, "finished": finished}],
        }

    def failure(self, step: Step, reason: str, **extra: Any) -> dict[str, Any]:
        """A failed step's update. Its policy halts the mission at once when it ends it (abort, rtl, retry), so
        that no step starts beside the abort or return-to-launch."""
        outcome = "skipped" if step.on_fail == "skip" else "failed"
        update: dict[str, Any] = {
            "status": {step.id: outcome},
            "errors": {step.id: reason},
            "log": [{"step": step.id, "status": outcome, "error": reason, **extra}],
        }
        halt = {"abort": "abort", "retry": "abort", "rtl": "rtl"}.get(step.on_fail)
        if halt:
            update["halt"] = halt
        return update

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
        spliced = dict(state.get("spliced") or {})
        policies = self.failure_routes(spliced, status)  # static steps have their own conditional edges
        if state.get("halt"):
            return Command(goto=policies or END)
        update: dict[str, Any] = {}
        preempted = state.get("preempted_by")
        if preempted:
            owned = [sid for sid in spliced if self.may_run(sid, {**state, "spliced": spliced})]
            if owned and all(status.get(sid) in FINISHED for sid in owned):
                if self.landed(owned, spliced, status):  # the sub-plan ended the flight: so does the mission
                    halted = {sid: "preempted" for sid in self.static if status.get(sid) not in FINISHED}
                    return Command(update={"status": halted, "halt": "landed"}, goto=END)
                preempted = update["preempted_by"] = ""  # its sub-plan is done: the plan goes on
        for trigger in self.plan.triggers:
            event = None if preempted else self.fires(trigger, {**state, "spliced": spliced})
            if event is None:
                continue
            count = (state.get("fired") or []).count(trigger.id)
            try:
                new = self.response(trigger, event, spliced, count + 1, update.setdefault("log", []))
            except StepFailed as exc:
                update["log"].append({"step": trigger.id, "status": "not fired", "error": exc.reason})
                continue
            spliced.update(new)
            update.setdefault("spliced", {}).update(new)
            update.setdefault("fired", []).append(trigger.id)
            update.setdefault("events", {})[trigger.id] = event
            update.setdefault("latched", {})[trigger.id] = None
            update.setdefault("log", []).append({"step": trigger.id, "status": "fired", "event": event})
            if trigger.preempt:
                preempted = update["preempted_by"] = trigger.id
        if self.declined:
            update.setdefault("log", []).extend(self.declined)
            self.declined = []
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
                    task = spliced[step_id]
                    snapshot = {**view, "event": task.get("event"), ALIASES: task.get(ALIASES)}
                    goto.append(Send(DYNAMIC, {"id": step_id, "state": snapshot}))
                else:
                    goto.append(step_id)
        goto.extend(policies)
        if marks:
            update.setdefault("status", {}).update(marks)
        return Command(update=update, goto=goto or END)

    def failure_routes(self, spliced: Mapping[str, Any], status: Mapping[str, str]) -> list[str]:
        """The policy nodes for spliced steps that failed (the policy nodes are idempotent)."""
        routes = {
            {"trigger_reflection": REFLECT, "rtl": RTL}.get(str(info["step"].get("on_fail", "abort")), ABORT)
            for step_id, info in spliced.items()
            if status.get(step_id) == "failed"
        }
        return sorted(routes)

    def fires(self, trigger: Trigger, state: Mapping[str, Any]) -> Any:
        """The event a trigger fires for now, or None: the event it was latched on while a flight action flew, else
        the first event its rule finds (:func:`trigger_events`) that the gate lets act."""
        if not may_fire(trigger, state):
            return None
        latched = (state.get("latched") or {}).get(trigger.id)
        if latched is not None:  # let act while a flight action flew: it fires for that event, in view or not
            return latched
        for event in trigger_events(trigger, state, self.env):
            if self.approved(trigger, event):
                return event
        return None

    def approved(self, trigger: Trigger, event: Any) -> bool:
        """The gate's verdict on an event (asked once per trigger and object); no gate approves everything."""
        if self.env.gate is None:
            return True
        key = (trigger.id, identity(event))
        if key not in self.verdicts:
            self.verdicts[key] = bool(self.env.gate(trigger, event))
            if not self.verdicts[key]:
                self.declined.append({"step": trigger.id, "status": "declined", "event": event})
        return self.verdicts[key]

    def preempting(self, state: Mapping[str, Any]) -> bool:
        """Whether a pre-empting trigger fires now (so a step about to start should wait for the scheduler)."""
        return any(t.preempt and self.fires(t, state) is not None for t in self.plan.triggers)

    def landed(self, owned: list[str], spliced: Mapping[str, Any], status: Mapping[str, str]) -> bool:
        return any(status.get(sid) == "ok" and spliced[sid]["step"].get("action") in ("land", "rtl") for sid in owned)

    def response(
        self, trigger: Trigger, event: Any, spliced: Mapping[str, Any], firing: int, log: list[dict[str, Any]]
    ) -> dict[str, dict[str, Any]]:
        """The steps a firing trigger splices in: the reasoner's plan when the trigger asks for one (``plan:
        reasoner``) and it passes the checks, else the trigger's own steps. A plan refused is logged with why."""
        origin = f"trigger:{trigger.id}"
        if trigger.plan == "reasoner" and self.env.planner is not None:
            try:
                proposed = self.env.planner(trigger, event)
                if proposed:
                    steps = self.checked(proposed, self.document_ids, event=True)
                    new = self.splice(steps, origin=origin, existing=spliced, event=event, firing=firing)
                    log.append({"step": trigger.id, "status": "planned", "by": [s.id for s in steps]})
                    return new
                log.append({"step": trigger.id, "status": "plan empty", "error": "the trigger's own steps run"})
            except StepFailed as exc:
                log.append({"step": trigger.id, "status": "plan rejected", "error": exc.reason})
            except Exception as exc:  # a failing planner is a result the mission handles: the playbook runs
                log.append({"step": trigger.id, "status": "plan failed", "error": f"{type(exc).__name__}: {exc}"})
        return self.splice(trigger.steps, origin=origin, existing=spliced, event=event, firing=firing)

    def checked(
        self, proposed: list[Step] | list[dict[str, Any]], taken: Iterable[str], *, event: bool = False
    ) -> list[Step]:
        """Steps a model proposed, checked like a mission's own (expressions, tools, limits) and by the
        environment's ``review`` (the runner's: scopes, approvals); :class:`StepFailed` lists every problem."""
        try:
            steps = STEPS_ADAPTER.validate_python(proposed)
        except ValidationError as exc:
            found = [f"{'.'.join(str(part) for part in e['loc'])}: {e['msg']}" for e in exc.errors()[:5]]
            raise StepFailed(f"the steps do not fit the mission language: {'; '.join(found)}") from None
        try:
            problems = check_revision(self.plan, steps, list(taken), self.tools, event=event)
        except ExpressionError as exc:
            problems = [str(exc)]
        if self.env.review is not None:
            problems += self.env.review(steps)
        if problems:
            raise StepFailed("; ".join(problems))
        return steps

    def splice(
        self,
        steps: list[Step],
        *,
        origin: str,
        existing: Mapping[str, Any],
        event: Any = None,
        firing: int = 1,
    ) -> dict[str, dict[str, Any]]:
        """Steps to run as tasks of ``__dynamic__``: a trigger's sub-plan (its ids get ``_<n>`` from its second
        firing on) or a reflection's revision (whose ids may not be any id of the mission)."""
        own = {s.id for t in self.plan.triggers if origin == f"trigger:{t.id}" for s in t.steps}  # its own ids
        taken = (self.document_ids - own) | set(existing)
        rename = {s.id: s.id if firing == 1 else f"{s.id}_{firing}" for s in steps}
        clash = sorted(new for new in rename.values() if new in taken)
        if clash:
            raise StepFailed(f"the steps reuse ids already in the mission: {', '.join(clash)}")
        out = {}
        for s in steps:
            deps = [*s.depends_on, *self.plan.dependencies.get(s.id, [])]
            unknown = [d for d in deps if d not in rename]
            if unknown:
                raise StepFailed(f"step {s.id!r} depends on {unknown}, which are not among the spliced steps")
            data = s.model_dump(mode="json", by_alias=True)
            data["id"], data["depends_on"] = rename[s.id], [rename[d] for d in s.depends_on]
            out[rename[s.id]] = {"step": data, "deps": [rename[d] for d in deps], "origin": origin, "event": event}
            if firing > 1:  # its expressions name the sub-plan's steps as written: this firing's are meant
                out[rename[s.id]][ALIASES] = rename
        return out

    # --- policies ---
    def reflect(self, state: MissionState) -> Command[Any]:
        status = state.get("status") or {}
        count = int(state.get("reflections") or 0)
        update: dict[str, Any] = {"status": {}, "spliced": {}, "waits_for": {}, "log": []}
        spliced = dict(state.get("spliced") or {})
        waits = dict(state.get("waits_for") or {})  # kept up to date, so several failures compose
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
                steps = self.checked(revised, [*self.document_ids, *spliced])
                new = self.splice(steps, origin=f"reflection:{step_id}", existing=spliced)
            except StepFailed as exc:
                update["log"].append({"step": step_id, "status": "revision rejected", "error": str(exc)})
                return Command(update={**update, "reflections": count}, goto=ABORT)
            spliced.update(new)
            update["spliced"].update(new)
            update["status"][step_id] = "replaced"
            leaves = [s.id for s in steps if not any(s.id in o.depends_on for o in steps)]
            view = {**state, "spliced": spliced, "waits_for": waits}
            for dependent in self.dependents_of(step_id, spliced, waits):
                others = [d for d in self.deps(dependent, view) if d != step_id]
                waits[dependent] = update["waits_for"][dependent] = [*others, *leaves]
            update["log"].append({"step": step_id, "status": "replaced", "by": [s.id for s in steps]})
        return Command(update={**update, "reflections": count}, goto=SCHEDULE)

    def dependents_of(self, step_id: str, spliced: Mapping[str, Any], waits: Mapping[str, list[str]]) -> list[str]:
        """Who waits for ``step_id``: by depends_on, in a splice, or since an earlier replacement."""
        found = [*self.dependents.get(step_id, []), *(sid for sid, i in spliced.items() if step_id in i["deps"])]
        found += [sid for sid, deps in waits.items() if step_id in deps]
        return list(dict.fromkeys(found))

    def abort(self, state: MissionState) -> dict[str, Any]:
        """Carry out the mission's ``on_abort`` (return to launch by default; land, or hold where it is): an
        aborted mission never flies on to a step that no longer makes sense, and never leaves the aircraft to
        chance."""
        failed = sorted(k for k, v in (state.get("status") or {}).items() if v == "failed")
        if any(entry.get("step") == ABORT for entry in state.get("log") or []):
            return {"halt": "abort"}
        status, error = self.last_resort(ON_ABORT_TOOLS[self.plan.on_abort])
        done = {"action": self.plan.on_abort, "result": status, "error": error}
        return {"halt": "abort", "log": [{"step": ABORT, "status": "aborted", "after": failed, **done}]}

    def rtl(self, state: MissionState) -> dict[str, Any]:
        if any(entry.get("step") == RTL for entry in state.get("log") or []):
            return {"halt": "rtl"}  # sent already: the aircraft is on its way home
        status, error = self.last_resort("flight.rtl")
        return {"halt": "rtl", "log": [{"step": RTL, "status": status, "error": error}]}

    def last_resort(self, tool: str) -> tuple[str, str | None]:
        """Call an abort's or a return's ``tool`` as the aircraft's state allows (:func:`ground_tool`: nothing on
        the ground disarmed, a landing in place on the ground armed); its status and error. It never raises."""
        try:
            chosen = ground_tool(tool, self.env.vehicle() or {})
            if chosen is None:
                return "not needed", None  # on the ground, disarmed: where an abort or a return would leave it
            result = self.env.dispatch(chosen, {}, None)
            return str(result.status), result.error
        except Exception as exc:  # the last resort must not raise past the mission
            return "error", f"{type(exc).__name__}: {exc}"


def compile_mission(
    plan: PolicyGraph,
    env: Environment,
    *,
    reflector: Reflector = abort_reflector,
    checkpointer: BaseCheckpointSaver | None = None,
    max_reflections: int = 3,
    tools: ToolCatalog | None = None,
) -> CompiledStateGraph:
    """The mission as a runnable graph; invoke it with ``initial_state(plan, params)``. ``tools``, the catalogue
    (a ToolRegistry), is what a reflector's revised ``call_tool`` steps are checked against."""
    rt = MissionRuntime(plan, env, reflector, max_reflections, tools)
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


__all__ = [
    "Environment",
    "Failure",
    "MissionState",
    "compile_mission",
]
