"""``agentic-uav run MISSION``: fly a mission end to end on the embedded defaults.

The simulated F450 runs behind its MAVLink endpoint on 127.0.0.1 (a free port), with perception on its tick: the
simulated camera over the mission's scene, the detector, the tracker and the World Model. The mission is compiled
onto the graph runtime with a SQLite checkpointer; every action goes through the tools executor — ``flight.*``
over the agent's MAVLink client, ``alerts.notify`` to SMTP or the run's outbox, ``perception.analyze_scene`` to the
reasoner. A trigger's condition is the tier-1 rule; before its sub-plan runs, the reasoner assesses the event
(tier 2) and only a ``high`` or ``critical`` assessment lets it act. With a model (``llm``, ``hybrid``) a trigger
marked ``plan: reasoner`` gets the model's response plan, checked like a mission file and by
:func:`~agentic_core.run.plan_review.review` (scopes, approvals), and the model reflects on failed steps. Steps
marked ``approval`` are answered by the headless policy, or (``approval="ask"``) the mission graph pauses on an
``interrupt``, the operator answers, and the graph resumes from its SQLite checkpoint. Everything lands in
``runs/<run-id>/``: ``trace.jsonl``, ``world_models.jsonl``, ``audit.jsonl``, ``alerts/`` and ``report.md`` with
``trajectory.png``.
"""

from __future__ import annotations

import gc
import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from flight.camera import CameraSpec
from flight.mavlink import MavlinkVehicle
from flight.sim import Environment as SimEnvironment
from flight.sim import Simulator
from flight.sim.detector import SimulatedCamera
from flight.sim.scene_file import load_scene
from flight.sim.scene_model import Scene
from flight.sim.simulator import VehicleState
from flight.tools import register_flight_tools
from flight.vehicle import VehicleClient
from tools import ToolError, ToolExecutor, ToolRegistry, ToolResult
from tools.audit import JsonlAuditLog
from tools.builtin import register_builtins
from tools.builtin.config import BuiltinConfig
from tools.function import spec_from_function

from ..graph import Command
from ..graph.checkpoint.sqlite import SqliteSaver
from ..mission import Environment, compile_mission, initial_state
from ..mission.compile import Reflector, abort_reflector
from ..mission.functions import MISSING, get_field
from ..mission.model import PolicyGraph, Trigger
from ..mission.params import parse_param
from ..mission.steps import scope
from ..mission.validate import load_mission
from ..perception.world_model import WorldModel
from ..reasoning.assessment import Assessment, Decision
from ..reasoning.model_reasoners import StructuredChat
from ..reasoning.planning import LLMPlanner
from ..reasoning.reasoners import Reasoner, make_reasoner
from ..reasoning.reflection import LLMReflector
from .attachments import materialize
from .operator import OperatorAnswer, TerminalOperator
from .perception_loop import PerceptionLoop
from .plan_review import review
from .report import RunSummary, TrackPoint, write_report
from .settings import AGENT, RunError, RunResult, RunSettings, default_scene
from .trace import TraceWriter

ACT_AT = ("high", "critical")
"""Assessments that let a trigger's sub-plan run."""

REFUSALS = frozenset({"plan rejected", "revision rejected", "plan failed", "not fired"})
"""Mission log entries that refuse a model's plan (or a firing): traced as ``refusal`` with every reason."""

MISSION_EVENTS = frozenset({"fired", "declined", "planned", "plan empty", "replaced", "reflection gave up"})
"""Other mission log entries worth a trace line."""

LOOK_AGAIN_S = 2.0
"""How long (flight time) an assessment of one object waits for its lost track to be seen again."""

WATCHED_TOOLS = frozenset({"flight.fly_to", "flight.orbit", "flight.hover"})
"""Long flight actions during which the triggers are watched: a leg is stopped when one holds for someone new."""


@dataclass(frozen=True)
class Interrupted:
    """What the mission sees of a flight action stopped for a trigger: done, and why it ended early."""

    output: dict[str, Any]
    status: str = "ok"
    error: str | None = None


class MissionRun:
    """One run: builds the vehicle, perception, tools and mission; :meth:`execute` flies it."""

    def __init__(
        self,
        settings: RunSettings,
        *,
        progress: TextIO | None = None,
        operator: Callable[[dict[str, Any]], OperatorAnswer] | None = None,
    ) -> None:
        self.settings = settings
        self.progress = progress
        if settings.approval == "ask" and operator is None:
            operator = TerminalOperator(sys.stdin, progress or sys.stderr, timeout_s=settings.approval_timeout_s)
        self.operator = operator
        stamp = time.strftime("%Y%m%d-%H%M%S")
        self.run_id = f"{stamp}-{settings.mission.stem}-{settings.reasoner}"
        self.run_dir = settings.runs_dir / self.run_id
        self.alerts_dir = self.run_dir / "alerts"
        self.registry = ToolRegistry()
        config = BuiltinConfig.from_env(
            outbox_dir=self.alerts_dir, incidents_db=self.run_dir / "incidents.db", attachment_dirs=[self.run_dir]
        )
        register_builtins(self.registry, config)
        scene_path = settings.scene or default_scene(settings.mission)
        self.scene: Scene | None = self._load_scene(scene_path) if scene_path else None
        home = self.scene.home.to_home() if self.scene else None
        self.sim = Simulator(environment=SimEnvironment(home=home) if home else None, seed=settings.seed)
        self.vehicle = MavlinkVehicle(self.sim, gcs=None, api=None)
        camera = SimulatedCamera(CameraSpec(rate_hz=settings.camera_hz))
        self.loop = PerceptionLoop(self.scene, seed=settings.seed, camera=camera) if self.scene else None
        self.track: list[TrackPoint] = []
        self._client: VehicleClient | None = None
        self._last_decision: Decision | None = None
        self._alert_sent_s: float | None = None
        self._lock = threading.Lock()
        # (trigger, object) -> the reasoner's assessment of it (asked once; None when it failed): whether to act
        self._assessments: dict[tuple[str, str | None], Assessment | None] = {}
        self._pending: tuple[str, str | None] | None = None  # approved while flying, not yet taken up by the mission
        self._subplan = False  # a trigger's sub-plan is running: its own flight actions are not interrupted
        self.decisions = 0
        self.vehicle.on_tick.append(self._sample_track)
        if self.loop is not None:
            self.vehicle.on_tick.append(self.loop.on_tick)
        register_flight_tools(self.registry, self._connect, targets=self._target)
        self.registry.register(spec_from_function(self._analyze_scene, name="perception.analyze_scene",
                                                  scopes=["perception:read"], timeout_s=120.0))  # fmt: skip
        try:
            self.plan = self._load_mission()
            self.reasoner: Reasoner = make_reasoner(settings.reasoner, llm=settings.llm, goal=self.plan.goal)
            self.params = {name: parse_param(self.plan, name, text) for name, text in settings.params.items()}
            self._param_values = dict(initial_state(self.plan, self.params).get("params") or {})
        except Exception:
            self.vehicle.close()
            raise
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.trace = TraceWriter(self.run_dir / "trace.jsonl", sim_clock=lambda: self.sim.time_s)
        self._world_log = (self.run_dir / "world_models.jsonl").open("a", encoding="utf-8")
        self.executor = ToolExecutor(
            self.registry, audit=JsonlAuditLog(self.run_dir / "audit.jsonl"), default_caller=AGENT
        )
        client = self._model_client()
        self.planner = (
            LLMPlanner(client, self.plan, self._tools_for_plans(), record=self._exchange("plan"))
            if client is not None
            else None
        )
        self.env = Environment(
            dispatch=self._dispatch,
            vehicle=self._vehicle_view,
            world=lambda: self.loop.world if self.loop else {"objects": [], "relations": []},
            approve=None if settings.approval == "ask" else self._approve,
            gate=self._gate,
            planner=self._plan if self.planner is not None else None,
            review=lambda steps: review(steps, self.registry, AGENT),
        )

    # ---- set-up ----

    def _load_mission(self) -> PolicyGraph:
        from ..mission.source import MissionError

        try:
            return load_mission(self.settings.mission, tools=self.registry)
        except MissionError as exc:
            raise RunError(str(exc)) from None

    def _load_scene(self, path: Path) -> Scene:
        from flight.sim.scene_file import SceneFileError

        try:
            return load_scene(path)
        except SceneFileError as exc:
            raise RunError(str(exc)) from None

    async def _connect(self) -> VehicleClient:
        client = await VehicleClient.connect(self.vehicle.address, timeout_s=10.0)
        self._client = client
        return client

    # ---- what the tools and the mission read ----

    def _target(self, object_id: str) -> tuple[float, float] | None:
        world = self.loop.world if self.loop else None
        found = world.get(object_id) if world else None
        return (found.pose.lat, found.pose.lon) if found else None

    def _vehicle_view(self) -> dict[str, Any]:
        client = self._client
        return client.telemetry.model_dump() if client is not None else {}

    def _sample_track(self, state: VehicleState) -> None:
        if not self.track or state.time_s - self.track[-1].sim_t >= 0.5:
            self.track.append(
                TrackPoint(
                    sim_t=state.time_s, north_m=state.north_m, east_m=state.east_m, alt_m=-state.down_m,
                    armed=state.armed,
                )
            )  # fmt: skip

    # ---- the reasoner, as a tool and as the trigger gate ----

    def _decide(self, focus: str | None, why: str) -> Decision:
        if self.loop is None:
            raise ToolError("no world model: this run has no scene, so there is nothing to analyse")
        world = self._look_again(focus) if focus is not None else self.loop.world
        decision = self.reasoner.assess(world, focus)
        with self._lock:
            self._last_decision = decision
            self.decisions += 1
            self._world_log.write(world.to_json() + "\n")
            self._world_log.flush()
        self.trace.write(
            "decision", why=why, focus=focus, **decision.model_dump(mode="json"),
            summary=f"{decision.reasoner} on {focus or 'the scene'}: "
            + (decision.assessment.severity if decision.assessment else f"failed ({decision.error})"),
        )  # fmt: skip
        self._say(f"decision ({why}): " + (decision.assessment.severity if decision.assessment else "failed"))
        return decision

    def _look_again(self, focus: str) -> WorldModel:
        """The World Model to judge ``focus`` on: when its track is lost just now (a run of missed detections, which
        a person lying still gets), look again for up to ``LOOK_AGAIN_S`` of flight time rather than judge a
        stale track; the latest model when that time is up, or at once when the object is not in the model."""
        assert self.loop is not None
        world = self.loop.world
        found = world.get(focus)
        if found is None or found.state != "lost":
            return world
        until_sim, until_wall = self.sim.time_s + LOOK_AGAIN_S, time.monotonic() + LOOK_AGAIN_S + 1.0
        while self.sim.time_s < until_sim and time.monotonic() < until_wall:
            time.sleep(0.005)
            world = self.loop.world
            found = world.get(focus)
            if found is None or found.state != "lost":
                break
        self.trace.write("log", level="info", summary=f"looked again at {focus}: "
                         + ("seen" if found is not None and found.state != "lost" else "still not seen"))  # fmt: skip
        return world

    def _analyze_scene(self, focus: str | None = None, min_confidence: float = 0.5) -> dict[str, Any]:
        """Assess the scene (or one object of the World Model) with the configured reasoner.

        Args:
            focus: an object id of the world model, or a description of what to look at
            min_confidence: fail when the assessment's confidence is below this
        """
        decision = self._decide(focus, "analyze_scene")
        if decision.assessment is None:
            raise ToolError(f"the reasoner failed: {decision.error}")
        if decision.assessment.persons_detected and decision.assessment.confidence < min_confidence:
            raise ToolError(
                f"confidence {decision.assessment.confidence:.2f} is below the required {min_confidence:.2f}"
            )
        return decision.model_dump(mode="json")

    def _gate(self, trigger: Trigger, event: Any) -> bool:
        """Tier 2: the reasoner assesses the event a trigger's rule found (once per object); only high or critical
        acts."""
        focus = _object_id(event)
        key = (trigger.id, focus)
        if key in self._assessments:
            if self._pending == key:
                self._pending = None  # the mission has taken it up
            return _acts(self._assessments[key])
        decision = self._decide(focus, f"trigger {trigger.id}")
        self._assessments[key] = decision.assessment
        act = _acts(decision.assessment)
        self.trace.write("trigger", trigger=trigger.id, event=focus, act=act,
                         summary=f"{trigger.id} on {focus}: {'act' if act else 'no action'}")  # fmt: skip
        return act

    # ---- the mission's tool calls ----

    def _dispatch(self, tool: str, args: dict[str, Any], timeout_s: float | None) -> ToolResult | Interrupted:
        if tool == "alerts.notify":
            args = materialize(
                args,
                out_dir=self.alerts_dir,
                stamp=f"{self.sim.time_s:08.1f}s",
                loop=self.loop,
                position=self._position,
                last_decision=lambda: self._last_decision.model_dump(mode="json") if self._last_decision else None,
            )
        if tool in WATCHED_TOOLS and self._pending is not None and not self._subplan:
            trigger_id, object_id = self._pending  # the rest of a repeat's pass: hold until the trigger fires
            return Interrupted({"interrupted_by": trigger_id, "event": object_id, "hold": "already holding"})
        if tool in WATCHED_TOOLS and self.plan.triggers and self.loop is not None and not self._subplan:
            watched = self._call_watching(tool, args, timeout_s)
            if isinstance(watched, Interrupted):
                return watched
            result = watched
        else:
            result = self.executor.call(tool, args, timeout_s=timeout_s)
        self.trace.write(
            "tool", name=tool, args=args, status=result.status, error=result.error, latency_s=result.latency_s
        )
        if tool == "alerts.notify" and result.status == "ok":
            self._alert_sent_s = self.sim.time_s
            self.trace.write("alert", summary=f"{args.get('subject')} → {result.output.get('delivered_via')}",
                             path=result.output.get("path"))  # fmt: skip
        self._say(f"{tool} {result.status}" + (f": {result.error}" if result.error else ""))
        return result

    def _call_watching(self, tool: str, args: dict[str, Any], timeout_s: float | None) -> ToolResult | Interrupted:
        """Run a flight action while watching the triggers; stop it (``flight.hold``) when one holds for an object
        the reasoner has not been asked about, so the mission's scheduler fires the trigger right away."""
        box: dict[str, ToolResult] = {}

        def call() -> None:
            box["result"] = self.executor.call(tool, args, timeout_s=timeout_s)

        worker = threading.Thread(target=call, name=f"run-{tool}", daemon=True)
        worker.start()
        while worker.is_alive():
            worker.join(0.1)
            found = self._new_event() if worker.is_alive() else None
            if found is None or not self._gate(*found):
                continue
            trigger_id, object_id = self._pending = (found[0].id, getattr(found[1], "id", None))
            hold = self.executor.call("flight.hold", {})
            worker.join()
            self.trace.write(
                "tool", name=tool, args=args, status="interrupted", trigger=trigger_id, event=object_id,
                hold=hold.status, summary=f"{tool} stopped: {trigger_id} holds for {object_id}",
            )  # fmt: skip
            self._say(f"{tool} stopped: trigger {trigger_id} holds for {object_id}")
            return Interrupted({"interrupted_by": trigger_id, "event": object_id, "hold": hold.status})
        return box["result"]

    def _new_event(self) -> tuple[Trigger, Any] | None:
        """The first trigger whose condition holds now for an object not yet put to the reasoner, and the object."""
        from ..mission.expressions import Expression

        where = scope({"params": self._param_values}, self.env)  # what a trigger reads, before any step's output
        for trigger in self.plan.triggers:
            try:
                value = Expression.parse(trigger.when).evaluate(where)
            except Exception:  # it reads step outputs or is not true yet: the scheduler will judge it
                continue
            events = value if isinstance(value, list) else [value] if value else []
            for event in events:
                if (trigger.id, _object_id(event)) not in self._assessments:
                    return trigger, event
        return None

    def _model_client(self) -> StructuredChat | None:
        """The reasoner's model client (llm, hybrid), which also plans and reflects; None for yolo and rules."""
        client: StructuredChat | None = getattr(self.reasoner, "client", None) or getattr(
            getattr(self.reasoner, "model", None), "client", None
        )
        return client

    def _reflector(self) -> Reflector:
        """A model's reflection when the reasoner has a model (llm, hybrid); else the default, which aborts."""
        client = self._model_client()
        if client is None:
            return abort_reflector
        return LLMReflector(client, self.plan, record=self._exchange("reflection"))

    def _exchange(self, kind: str) -> Callable[[dict[str, Any]], None]:
        """Traces one plan or reflection asked of the model, with a one-line summary for the timeline."""

        def record(entry: dict[str, Any]) -> None:
            self.trace.write(kind, **entry, summary=f"{entry.get('model')}: {entry.get('outcome')}")
            self._say(f"{kind} by {entry.get('model')}: {entry.get('outcome')}")

        return record

    def _tools_for_plans(self) -> list[Any]:
        """The tools a model's plan may name: those the agent holds every scope of."""
        return [
            self.registry.describe(n) for n in self.registry.names() if not AGENT.missing(self.registry.get(n).scopes)
        ]

    def _plan(self, trigger: Trigger, event: Any) -> list[dict[str, Any]] | None:
        """The model's response plan for an event a trigger fired on (``plan: reasoner``); the mission checks it."""
        assert self.planner is not None
        assessment = self._assessments.get((trigger.id, _object_id(event)))
        self._say(f"planning the response to {trigger.id} on {_object_id(event)}")
        return self.planner(assessment, event)

    def _position(self) -> dict[str, Any] | None:
        view = self._vehicle_view()
        if not view:
            return None
        last = self._last_decision.assessment if self._last_decision else None
        subject = self._target(last.subject_id) if last and last.subject_id else None
        return {
            "aircraft": {k: view.get(k) for k in ("lat_deg", "lon_deg", "alt_m")},
            "subject": {"id": last.subject_id, "lat": subject[0], "lon": subject[1]} if subject and last else None,
        }

    def _approve(self, request: dict[str, Any]) -> bool:
        approved = self.settings.approval == "approve"
        verdict = "approved" if approved else "declined"
        self.trace.write("approval", request=request, answer=approved, via="policy",
                         summary=f"{request.get('step')}: {verdict} (headless policy)")  # fmt: skip
        return approved

    def _ask_operator(self, request: dict[str, Any]) -> bool:
        """An approval the mission paused for: the operator answers while the simulation runs at real time at
        most, so the aircraft hovers (and its battery drains) for as long as the real wait."""
        assert self.operator is not None
        self._say(f"waiting for the operator: {request.get('question')}")
        fast = self.settings.speed is None or self.settings.speed > 1.0
        if fast:
            self.vehicle.stop()
            self.vehicle.start(speed=1.0)
        try:
            answer = self.operator(request)
        finally:
            if fast:
                self.vehicle.stop()
                self.vehicle.start(speed=self.settings.speed)
        self.trace.write("approval", request=request, answer=answer.approved, via="operator", said=answer.said,
                         summary=f"{request.get('step')}: {answer.why}")  # fmt: skip
        self._say(f"{request.get('step')}: {answer.why}")
        return answer.approved

    def _say(self, text: str) -> None:
        if self.progress is not None:
            print(f"[{self.sim.time_s:7.1f} s] {text}", file=self.progress, flush=True)

    # ---- running ----

    def prepare(self) -> None:
        """Get ready before take-off, so the first event costs no more than any: draw one picture (the annotator
        loaded) and open the model's connection, reporting a model server that does not answer now rather than at
        the first event (the run goes on: a failing model is a result the agent handles)."""
        if self.loop is not None:
            self.loop.warm()
        client = self._model_client()
        warm = getattr(client, "warm", None)
        if callable(warm):
            problem = warm()
            if problem is not None:
                self.trace.write("log", level="warning", summary=f"the model server does not answer: {problem}")
                self._say(f"warning: the model server does not answer ({problem}); its calls will fail")

    def execute(self) -> RunResult:
        """Fly the mission; always stops the vehicle and writes the report."""
        wall0 = time.monotonic()
        self.trace.write("run", event="start", mission=str(self.settings.mission), reasoner=self.reasoner.name,
                         summary=f"start {self.plan.plan_id} with {self.reasoner.name}")  # fmt: skip
        self.prepare()
        self.vehicle.start(speed=self.settings.speed)
        final: dict[str, Any] = {}
        outcome = "failed"
        over = False
        try:
            with setup_frozen(), SqliteSaver.from_conn_string(str(self.run_dir / "checkpoints.db")) as saver:
                graph = compile_mission(
                    self.plan, self.env, checkpointer=saver, reflector=self._reflector(), tools=self.registry
                )
                config = {"configurable": {"thread_id": self.run_id}, "recursion_limit": 10_000}
                inputs: Any = initial_state(self.plan, self.params)
                while not over:
                    for update in graph.stream(inputs, config, stream_mode="updates"):
                        if time.monotonic() - wall0 > self.settings.max_wall_s:
                            over = True
                            break
                        for node, change in update.items():
                            if isinstance(change, dict):
                                self._follow(node, change)
                    pending = graph.get_state(config).interrupts
                    if over or not pending:
                        break
                    # a step waits for the operator: ask, then resume the graph from its checkpoint
                    inputs = Command(resume={i.id: self._ask_operator(dict(i.value)) for i in pending})
                final = dict(graph.get_state(config).values)
            halt = final.get("halt")
            outcome = {"abort": "aborted", "rtl": "returned"}.get(halt or "", "completed")
            if over:
                outcome = "interrupted"
                self.trace.write(
                    "log", level="error", summary=f"over {self.settings.max_wall_s:.0f} s of wall time: RTL"
                )
                self.executor.call("flight.rtl", {})
        except Exception as exc:  # a bug must still land the aircraft and leave a report
            self.trace.write("log", level="error", error=f"{type(exc).__name__}: {exc}")
            outcome = "failed"
        finally:
            self._finish()
        summary = self._summary(outcome, time.monotonic() - wall0)
        report = write_report(self.run_dir, summary, self.trace.records, self.track, self.scene)
        return RunResult(self.run_id, self.run_dir, report, summary, final, list(self.track))

    def _follow(self, node: str, change: dict[str, Any]) -> None:
        """Trace what one node changed: step statuses, and the mission's log of triggers, plans and refusals."""
        if "preempted_by" in change:
            self._subplan = bool(change["preempted_by"])
        for step, status in (change.get("status") or {}).items():
            self.trace.write("step", node=node, step=step, status=status, summary=f"{step} {status}")
        for entry in change.get("log") or []:
            status = str(entry.get("status"))
            if status in REFUSALS:
                self.trace.write("refusal", **entry, summary=f"{entry.get('step')}: {status}: {entry.get('error')}")
                self._say(f"{entry.get('step')}: {status}: {entry.get('error')}")
            elif status in MISSION_EVENTS:
                self.trace.write("mission", **entry, summary=f"{entry.get('step')}: {status}")

    def _finish(self) -> None:
        self.trace.write("run", event="end", summary="end")
        self.close()

    def close(self) -> None:
        """Release what the run holds without flying it (:meth:`execute` does this itself): the executor's workers,
        the vehicle's socket, the open logs. Safe to call twice."""
        self.executor.close()
        self.vehicle.close()
        self._world_log.close()
        self.trace.close()

    def _summary(self, outcome: str, wall_s: float) -> RunSummary:
        decisions = self.trace.of_kind("decision")
        exchanges = self.trace.of_kind("plan") + self.trace.of_kind("reflection")  # one model call each
        alerts = sorted(str(p) for p in self.alerts_dir.glob("*") if p.is_file()) if self.alerts_dir.exists() else []
        return RunSummary(
            run_id=self.run_id,
            mission=str(self.settings.mission),
            scene=self.scene.id if self.scene else None,
            reasoner=self.reasoner.name,
            outcome=outcome,
            sim_duration_s=self.sim.time_s,
            wall_duration_s=wall_s,
            alerts=alerts,
            decisions=len(decisions),
            llm_calls=sum(int(d.get("llm_calls", 0)) for d in decisions) + len(exchanges),
            tokens=sum(int(d.get("prompt_tokens", 0)) + int(d.get("completion_tokens", 0)) for d in decisions)
            + sum(int(e.get("tokens", 0)) for e in exchanges),
            llm_calls_saved=getattr(self.reasoner, "saved", None),
            frames=self.loop.frames if self.loop else 0,
            perception_ms_per_frame=1000 * self.loop.busy_s / self.loop.frames
            if self.loop and self.loop.frames
            else None,
            casualties=list(self.scene.ground_truth.casualties) if self.scene else [],
            first_detected_s={k: v for k, v in (self.loop.first_detected.items() if self.loop else [])
                              if self.scene and k in self.scene.ground_truth.casualties},
            alert_sent_s=self._alert_sent_s,
        )  # fmt: skip


@contextmanager
def setup_frozen() -> Iterator[None]:
    """Leave everything that exists now (a run's set-up: the scene, the vehicle, the compiled mission, the models)
    out of the garbage collector's passes until the block ends, so a collection during the flight, on the way from
    a frame to an alert say, walks only what the flight made (``gc.freeze``; undone at the end)."""
    gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _acts(assessment: Assessment | None) -> bool:
    """Whether an assessment lets a trigger's sub-plan run (:data:`ACT_AT`); a failed one does not."""
    return assessment is not None and assessment.severity in ACT_AT


def _object_id(event: Any) -> str | None:
    """The world-model object a trigger found (None for an event that is not an object)."""
    found = get_field(event, "id")
    return None if found is MISSING else str(found)


def run_mission(
    settings: RunSettings,
    progress: TextIO | None = sys.stderr,
    operator: Callable[[dict[str, Any]], OperatorAnswer] | None = None,
) -> RunResult:
    """Build and fly one run (see the module docstring); raises :class:`RunError` for bad input. ``operator``
    answers approvals when ``settings.approval`` is ``ask`` (default: the terminal)."""
    return MissionRun(settings, progress=progress, operator=operator).execute()


__all__ = [
    "AGENT",
    "MissionRun",
    "RunError",
    "RunResult",
    "RunSettings",
    "default_scene",
    "run_mission",
    "setup_frozen",
]
