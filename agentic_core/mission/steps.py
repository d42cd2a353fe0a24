"""Running one mission step: preconditions, operator approval, argument templates, retries, the tool call.

Every action goes through ``dispatch(tool, args, timeout_s)``: the compiler is given that callable (the tools
executor, once the tools layer lands; a recording stand-in in tests), so physical and digital actions take one
path. ``wait_until``, ``repeat`` and ``branch`` call no tool of their own; a ``survey`` flies its lawnmower legs
as ``flight.fly_to`` calls.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field, replace
from typing import Any, Protocol

from ..contracts import AgenticUAVError, RunFailure
from ..graph import GraphInterrupt, interrupt
from .expressions import Expression, ExpressionError
from .geometry import lawnmower
from .model import ACTION_TOOLS, BranchStep, CallToolStep, RepeatStep, Step, SurveyStep, WaitUntilStep, step_args
from .templates import render


class ToolOutcome(Protocol):
    """What a dispatcher returns: the ToolResult contract's ``status``, ``output`` and ``error``."""

    @property
    def status(self) -> str: ...
    @property
    def output(self) -> Any: ...
    @property
    def error(self) -> str | None: ...


Dispatch = Callable[[str, dict[str, Any], float | None], ToolOutcome]
Provider = Callable[[], Any]


@dataclass
class Environment:
    """What steps need from outside the graph: the dispatcher, live state providers and policies."""

    dispatch: Dispatch
    vehicle: Provider = dict
    world: Provider = field(default=lambda: {"objects": [], "relations": []})  # an empty world model
    approve: Callable[[dict[str, Any]], Any] | None = None  # headless approval policy; None: ask via interrupt()
    gate: Callable[[Any, Any], bool] | None = None  # (trigger, event) -> act? The reasoner's say; None: always act
    planner: Callable[[Any, Any], list[dict[str, Any]] | None] | None = None  # (trigger, event) -> proposed steps
    review: Callable[[list[Any]], list[str]] | None = None  # problems of proposed steps beyond the validator's
    clock: Callable[[], float] = time.monotonic
    sleep: Callable[[float], None] = time.sleep
    stopping: Callable[[], str | None] = lambda: None
    """Why the run is being paused or stopped (the control port), None to go on: a ``wait_until``, which calls no
    tool that could be interrupted, gives way to it at its next poll."""
    run_id: str | None = None
    """The run these steps fly in. An approval kept over a pause holds in this run only (its ``--resume`` too):
    a fork of it, a new run from one of its checkpoints, asks the operator again."""


class StepFailed(RunFailure):
    """The step did not achieve its action; ``reason`` is what the agent (and the log) see."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class Interrupted:
    """What a dispatcher returns for an action it stopped before the end, not a failure: a trigger took over the
    aircraft (``trigger`` fired for ``event``) or the operator paused or stopped the run. The step runs again later."""

    reason: str
    trigger: str | None = None
    event: Any = None
    status: str = "interrupted"
    error: str | None = None

    @property
    def output(self) -> dict[str, Any]:
        return {"interrupted": self.reason, "trigger": self.trigger}


class StepInterrupted(AgenticUAVError):
    """Raised out of a step whose action was :class:`Interrupted`; the mission runtime reschedules the step.
    ``approved`` holds the arguments the operator approved for it, if it asked."""

    def __init__(self, outcome: Interrupted, approved: dict[str, Any] | None = None) -> None:
        super().__init__(outcome.reason)
        self.outcome = outcome
        self.approved = approved


@dataclass(frozen=True)
class StepCall:
    """Which step (and where in it) a dispatch belongs to: its path (``patrol/leg_north``), the repeat's pass, the
    attempt and the dispatch's number within the attempt. :meth:`key` names the call uniquely and the same way when
    a resumed run does it again, so a side effect done before a crash can be recognised (an idempotency key)."""

    path: str
    origin: str | None = None
    rerun: int = 0
    """How often the step was interrupted before (an interrupted step runs again: a new call, not a replay)."""
    iteration: int | None = None
    attempt: int = 1
    number: int = 0
    state: Mapping[str, Any] | None = field(default=None, compare=False, repr=False)
    """The mission state the step started from (what a trigger watch evaluates against)."""

    def key(self) -> str:
        root, _, rest = self.path.partition("/")
        where = (f"{root}~{self.rerun}" if self.rerun else root) + (f"/{rest}" if rest else "")
        where = where if self.iteration is None else f"{where}#{self.iteration}"
        return f"{where}:{self.attempt}.{self.number}"


_CALL: ContextVar[StepCall | None] = ContextVar("agentic_uav_step_call", default=None)


def current_call() -> StepCall | None:
    """The step call being dispatched in this thread (None outside a mission step)."""
    return _CALL.get()


@contextmanager
def step_call(path: str, origin: str | None = None, state: Mapping[str, Any] | None = None) -> Iterator[None]:
    """Run the block as the mission step ``path`` (the runtime's node for one step), started from ``state``; the
    times the log says it was interrupted before make its run number."""
    log = (state or {}).get("log") or []
    rerun = sum(1 for e in log if e.get("step") == path and e.get("status") == "interrupted")
    token = _CALL.set(StepCall(path=path, origin=origin, rerun=rerun, state=state))
    try:
        yield
    finally:
        _CALL.reset(token)


@contextmanager
def within(*, child: str | None = None, **changes: Any) -> Iterator[None]:
    """Run the block as part of the current step call, changed: a nested step (``child``), a pass, an attempt."""
    now = _CALL.get() or StepCall(path="?")
    if child is not None:
        changes = {"path": f"{now.path}/{child}", "attempt": 1, "number": 0, **changes}
    token = _CALL.set(replace(now, **changes))
    try:
        yield
    finally:
        _CALL.reset(token)


SCOPE_ROOTS = ("params", "steps", "vehicle", "world", "event", "mission")
"""What expressions may read, besides step ids: parameters, step outputs (``steps.<id>``), the vehicle's state,
the world model, the event that fired a trigger, and the mission itself (``mission.status``, each step's status;
``mission.declined``, the steps the operator said no to). :func:`scope` provides exactly these."""


ALIASES = "aliases"
"""The key of a spliced step's state holding, for a trigger's second firing on, its sub-plan's ids as written →
this firing's ids (``confirm`` → ``confirm_2``)."""


def scope(state: Mapping[str, Any], env: Environment, event: Any = None) -> dict[str, Any]:
    """The values of :data:`SCOPE_ROOTS`, and each step's output under its own id too (the paper's
    ``step_1.wind_speed``). In a trigger's sub-plan fired again, its steps' ids as written name this firing's
    steps (:data:`ALIASES`): ``confirm.assessment`` is this firing's confirmation, never an earlier one's."""
    outputs = dict(state.get("outputs") or {})
    status = dict(state.get("status") or {})
    refused = declined(state)
    aliases: Mapping[str, str] = state.get(ALIASES) or {}
    if aliases:
        for table in (outputs, status):
            mine = {written: table[renamed] for written, renamed in aliases.items() if renamed in table}
            for written in aliases:
                table.pop(written, None)  # an earlier firing's: unknown here until this firing's has run
            table.update(mine)
        written_as = {renamed: written for written, renamed in aliases.items()}
        refused = [written_as.get(s, s) for s in refused if s not in aliases]
    roots = {
        "params": dict(state.get("params") or {}),
        "steps": outputs,
        "vehicle": env.vehicle(),
        "world": env.world(),
        "event": event if event is not None else state.get("event"),
        "mission": {"status": status, "declined": refused},
    }
    return {**outputs, **roots}


DECLINED = "operator did not approve"


def declined(state: Mapping[str, Any]) -> list[str]:
    """The steps the operator said no to (``mission.declined`` in expressions), in the order they were asked."""
    return [step for step, reason in (state.get("errors") or {}).items() if str(reason).startswith(DECLINED)]


def evaluate(text: str, where: Mapping[str, Any]) -> Any:
    """An expression's value; one that cannot be evaluated fails the step."""
    try:
        return Expression.parse(text).evaluate(where)
    except ExpressionError as exc:
        raise StepFailed(f"cannot evaluate {text!r}: {exc}") from None


def check(text: str, where: Mapping[str, Any]) -> bool:
    return bool(evaluate(text, where))


MAX_SURVEY_LEGS = 2_000


def _call(env: Environment, tool: str, args: dict[str, Any], timeout_s: float | None) -> Any:
    """One dispatch. A dispatcher that raises, or answers with something that is not a result, fails the step:
    the mission's on_fail decides what happens, it never crashes. An :class:`Interrupted` action raises
    :class:`StepInterrupted`."""
    now = _CALL.get()
    if now is not None:
        _CALL.set(replace(now, number=now.number + 1))
    try:
        result = env.dispatch(tool, args, timeout_s)
    except GraphInterrupt:
        raise
    except Exception as exc:
        raise StepFailed(f"{tool} raised {type(exc).__name__}: {exc}") from None
    if isinstance(result, Interrupted):
        raise StepInterrupted(result)
    status = getattr(result, "status", None)
    if not isinstance(status, str):
        raise StepFailed(f"{tool}: the dispatcher answered {type(result).__name__}, not a result with a status")
    if status != "ok":
        raise StepFailed(f"{tool} returned {status}: {getattr(result, 'error', None) or 'no detail'}")
    return getattr(result, "output", None)


def _approve(step: Step, args: dict[str, Any], env: Environment) -> dict[str, Any]:
    """Ask the operator; the arguments to fly with: the step's, or the operator's edits of them (an answer
    ``{"approve": true, "args": {...}}``), which may change only arguments the step has."""
    request = {"step": step.id, "action": step.action, "args": args, "question": f"approve {step.action} ({step.id})?"}
    answer: Any = env.approve(request) if env.approve is not None else interrupt(request)
    edits: Any = None
    if isinstance(answer, Mapping):
        answer, edits = answer.get("approve"), answer.get("args")
    if answer not in (True, "approve", "approved", "yes", "y"):
        raise StepFailed(f"{DECLINED} {step.id} (answered {answer!r})")
    if edits is None:
        return args
    if not isinstance(edits, Mapping) or not edits:
        raise StepFailed(f"{step.id}: the operator's edits are not arguments (got {edits!r})")
    unknown = sorted(set(edits) - set(args))
    if unknown:
        raise StepFailed(f"{step.id}: the operator's edits name {unknown}, not arguments of this step ({sorted(args)})")
    return {**args, **edits}


def prepare(step: Step, state: Mapping[str, Any], env: Environment) -> dict[str, Any]:
    """What runs once per step, before any attempt: preconditions, argument templates, operator approval. A step
    the operator approved before a pause interrupted it flies again with the arguments approved, not asked again."""
    where = scope(state, env)
    for text in step.preconditions:
        if not check(text, where):
            raise StepFailed(f"precondition {text!r} is false")
    kept = kept_approval(state, step, env)
    if kept is not None:
        return kept
    try:
        args: dict[str, Any] = render(step_args(step), where)
    except ExpressionError as exc:
        raise StepFailed(f"cannot fill in the arguments: {exc}") from None
    if step.approval:
        args = _approve(step, args, env)
    return args


def keep_approval(args: Mapping[str, Any], env: Environment) -> dict[str, Any]:
    """What the mission state keeps of an approval interrupted by a pause: the arguments approved, and the run
    they were approved in."""
    return {"run": env.run_id, "args": dict(args)}


def kept_approval(state: Mapping[str, Any], step: Step, env: Environment) -> dict[str, Any] | None:
    """The arguments the operator approved for ``step`` before a pause, when the approval was given in this run
    (None otherwise: ask). A fork carries its original's state but not its operator's yes."""
    kept = (state.get("approved") or {}).get(step.id) if step.approval else None
    if not isinstance(kept, Mapping) or kept.get("run") != env.run_id or not isinstance(kept.get("args"), Mapping):
        return None
    return dict(kept["args"])


def _survey_legs(args: Mapping[str, Any]) -> list[tuple[float, float]]:
    try:
        polygon = [(float(p["lat"]), float(p["lon"])) for p in args["polygon"]]
        legs = lawnmower(polygon, float(args["spacing_m"]))
    except (TypeError, ValueError, KeyError) as exc:
        raise StepFailed(f"survey: bad polygon or spacing ({exc})") from None
    if len(legs) > MAX_SURVEY_LEGS:
        raise StepFailed(f"survey: {len(legs)} legs is more than {MAX_SURVEY_LEGS}; widen spacing_m")
    return legs


def perform(step: Step, args: dict[str, Any], state: Mapping[str, Any], env: Environment) -> Any:
    """One attempt of a step's action, with arguments already filled in. Returns its output."""
    if isinstance(step, CallToolStep):
        return _call(env, step.tool, args, step.timeout_s)
    if isinstance(step, SurveyStep):
        legs = _survey_legs(args)
        for lat, lon in legs:
            leg = {"lat": lat, "lon": lon, "alt_m": args["altitude_m"]}
            if args.get("speed_mps") is not None:
                leg["speed_mps"] = args["speed_mps"]
            _call(env, "flight.fly_to", leg, step.timeout_s)
        return {"legs": len(legs)}
    if isinstance(step, WaitUntilStep):
        deadline = None if step.timeout_s is None else env.clock() + step.timeout_s
        while not check(step.condition, scope(state, env)):
            if (reason := env.stopping()) is not None:
                raise StepInterrupted(Interrupted(reason))
            if deadline is not None and env.clock() >= deadline:
                raise StepFailed(f"{step.condition!r} still false after {step.timeout_s:g} s")
            env.sleep(step.poll_s)
        return {"waited": True}
    if isinstance(step, BranchStep):
        chosen = step.then if check(step.if_, scope(state, env)) else step.else_
        return run_sequence(chosen, state, env)
    if isinstance(step, RepeatStep):
        raise AssertionError("repeat steps run one iteration at a time: see run_iteration")
    return _call(env, ACTION_TOOLS[step.action], args, step.timeout_s)


def run_with_retries(step: Step, state: Mapping[str, Any], env: Environment) -> tuple[Any, int]:
    """Run a step: prepare it once (an approval is asked once), then up to ``1 + max_retries`` attempts.
    Returns (output, attempts) or raises StepFailed."""
    args = prepare(step, state, env)
    attempts = 0
    while True:
        attempts += 1
        try:
            with within(attempt=attempts, number=0):
                return perform(step, args, state, env), attempts
        except StepFailed as failed:
            if attempts > step.max_retries:
                failed.reason += f" (after {attempts} attempt{'s' if attempts > 1 else ''})"
                raise
        except StepInterrupted as stopped:
            if step.approval:
                stopped.approved = args
            raise


def run_sequence(steps: list[Step], state: Mapping[str, Any], env: Environment) -> dict[str, Any]:
    """Run nested steps in order (a branch arm or one repeat iteration); a nested ``skip`` failure is passed over,
    any other nested failure fails the parent."""
    outputs = dict(state.get("outputs") or {})
    for step in steps:
        local = {**state, "outputs": outputs}
        try:
            with within(child=step.id):
                outputs[step.id], _ = run_with_retries(step, local, env)
        except StepFailed as failed:
            if step.on_fail != "skip":
                raise StepFailed(f"{step.id}: {failed.reason}") from None
    return {s.id: outputs[s.id] for s in steps if s.id in outputs}


def run_iteration(
    step: RepeatStep, state: Mapping[str, Any], env: Environment, done: int
) -> tuple[dict[str, Any], bool]:
    """One pass of a repeat's body; returns (output, finished) — finished when ``until`` holds or at the limit.
    The repeat's own preconditions and approval are checked before its first pass."""
    args = prepare(step, state, env) if done == 0 else None
    try:
        with within(iteration=done + 1):
            body = run_sequence(step.steps, state, env)
    except StepInterrupted as stopped:
        if step.approval and args is not None:
            stopped.approved = args
        raise
    output = {"iterations": done + 1, "last": body}
    outputs = {**(state.get("outputs") or {}), **body, step.id: output}
    finished = check(step.until, scope({**state, "outputs": outputs}, env)) or done + 1 >= step.max_iterations
    return output, finished
