"""``agentic-uav run MISSION``: fly a mission end to end — the composition root that assembles a run and starts it.

A run is: a vehicle backend (:mod:`~agentic_core.run.backends`: the in-process simulator, or any vehicle at a
MAVLink address), perception over the mission's scene fed by the vehicle's telemetry, the tools (built-ins, the
``flight.*`` tools over the agent's MAVLink client, ``perception.analyze_scene``), the reasoner, and the agent
(:mod:`agentic_core.agent`: the gate, the dispatcher, the loop, the control port, the event bus). The mission is
compiled onto the graph runtime with a SQLite checkpointer. Everything lands in ``runs/<run-id>/``: ``run.json``,
``trace.jsonl`` (every event), ``telemetry.jsonl``, ``world_models.jsonl``, ``audit.jsonl``, ``snapshot.json``,
``checkpoints.db``, ``flight.tlog``, ``alerts/`` and ``report.md`` with its plots. A killed run continues with
:meth:`MissionRun.resume` (``agentic-uav run --resume RUN_ID``): the graph from its checkpoint, the simulator from
its snapshot, and no side effect twice (each call's idempotency key is in the audit log).

This module assembles the run (:class:`MissionRun`) and answers what its parts read of it; :mod:`~agentic_core.run.fly`
flies it, from the vehicle reached to the report.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any, TextIO

from flight.sim.detector import SimulatedCamera
from flight.sim.gains_file import load_gains
from flight.sim.scene_model import Scene
from flight.tools import register_flight_tools
from flight.vehicle import VehicleClient
from tools import ToolError, ToolExecutor
from tools.audit import JsonlAuditLog
from tools.builtin.config import BuiltinConfig
from tools.function import spec_from_function

from ..agent import ControlPort, Dispatcher, EventBus, Gate, Pace, policy_approval
from ..agent.control import Operator
from ..agent.envelope import Envelope
from ..agent.failsafes import TelemetryFailsafes, VehicleTexts
from ..agent.gate import unsure
from ..agent.ports import WorldSource
from ..contracts import RunEvent, TelemetrySample
from ..mission import Environment
from ..mission.model import Trigger
from ..mission.params import parse_param
from ..mission.triggers import object_id, trigger_events
from ..perception.world_model import WorldModel
from ..reasoning.assessment import Decision
from ..reasoning.reasoners import make_reasoner
from .assembly import NoWorld, load_run_mission, load_run_scene, setup_frozen
from .attachments import materialize
from .backends import Backend, LinkBackend, SimBackend
from .detector_choice import camera_spec
from .faults import SCHEDULE, FaultSchedule
from .fleet_seat import FleetSeat
from .fly import fly
from .link_key import keep_signing_key, run_signing_key
from .model_check import require_model
from .model_side import ModelSide, close_client, model_client
from .operator import OperatorAnswer, TerminalOperator
from .own_tools import ANALYZE_SCENE, ANALYZE_SCENE_SCOPES
from .perception_loop import PerceptionLoop
from .plan_review import review
from .privilege import destination_review, mission_caller
from .readable import TruthLinks, readable
from .report import TrackPoint
from .responses import ResponseLedger
from .resume_point import Resumption, RunHold, open_resume
from .run_clock import resumed_at
from .run_memory import with_memory
from .run_tools import run_tools
from .settings import AGENT, RunError, RunResult, RunSettings, default_scene
from .state_files import Snapshot, SnapshotWriter, read_jsonl, read_record
from .stops import where_it_ended
from .trace import TelemetryLog, TraceWriter
from .vehicle_lost import silence_bound
from .world_map import WORLD_MAP_FILE, WorldMapLog


class MissionRun:
    """One run, assembled; :meth:`execute` flies it (or goes on with it, when made by :meth:`resume`)."""

    def __init__(
        self,
        settings: RunSettings,
        *,
        progress: TextIO | None = None,
        operator: Operator | None = None,
        run_id: str | None = None,
        fleet: FleetSeat | None = None,
    ) -> None:
        self.settings = settings
        self.fleet = fleet  # a swarm's member: its shared pace, its lockstep vehicle, the swarm's tools
        self.progress = progress
        self._operator = operator
        self.resuming = run_id is not None
        self.run_id = run_id or f"{time.strftime('%Y%m%d-%H%M%S')}-{settings.mission.stem}-{settings.reasoner}"
        self.run_dir = settings.runs_dir / self.run_id
        self.alerts_dir = self.run_dir / "alerts"
        resumed = open_resume(self.run_dir, self.run_id) if self.resuming else Resumption()  # before anything flies
        self.hold, snapshot, self.go_on = resumed.hold, resumed.snapshot, self.resuming and not resumed.from_start
        self.config = config = BuiltinConfig.from_env(
            outbox_dir=self.alerts_dir, incidents_db=self.run_dir / "incidents.db", attachment_dirs=[self.run_dir]
        )
        self.registry, self.agent = run_tools(settings.tools, config)
        scene_path = settings.scene or default_scene(settings.mission)
        self.scene: Scene | None = load_run_scene(scene_path) if scene_path else None
        self.pace = fleet.pace if fleet else Pace(settings.speed)
        tlog = self.run_dir / "flight.tlog"
        snapshot_s = snapshot.sim_t if snapshot is not None and snapshot.sim_t is not None else 0.0
        # a vehicle of its own goes on from where the run's files end; the simulator from the snapshot it restores
        self._clock0 = resumed_at(self.run_dir, snapshot_s) if self.resuming and settings.connect else snapshot_s
        self.backend: Backend = fleet.backend(self) if fleet else (
            LinkBackend(settings.connect, camera_hz=settings.camera_hz, tlog=tlog, signing_key=settings.signing_key,
                        start_s=self._clock0)
            if settings.connect
            else SimBackend(
                home=self.scene.home.to_home() if self.scene else None, seed=settings.seed, pace=self.pace,
                restore=snapshot.vehicle if snapshot else None, gcs=settings.gcs_address, tlog=tlog,
                signing_key=run_signing_key(self.run_dir), gains=load_gains(settings.gains) if settings.gains else None,
            )
        )  # fmt: skip
        try:
            self._assemble(snapshot)
        except Exception:
            self.backend.close()
            RunHold.drop(self.hold)
            raise

    def _assemble(self, snapshot: Snapshot | None) -> None:
        settings = self.settings
        camera = SimulatedCamera(camera_spec(settings.detector, settings.camera_hz))
        self.loop = (
            PerceptionLoop(
                self.scene, seed=settings.seed, camera=camera, render=settings.render, detector=settings.detector
            )
            if self.scene
            else None
        )
        if self.loop is not None and snapshot is not None and snapshot.world is not None:
            self.loop.restore(WorldModel.model_validate(snapshot.world), snapshot.last_seen, snapshot.tracks)
            self.loop.first_detected.update(snapshot.first_detected)
        self.last_sample: TelemetrySample | None = None
        self._client: VehicleClient | None = None
        self.backend.on_sample(self._on_sample)
        if self.loop is not None:
            self.backend.on_sample(self.loop.on_sample)
        register_flight_tools(self.registry, self._connect, targets=self._target)
        if self.fleet is not None:
            self.fleet.tools(self.registry, self)
        self.registry.register(spec_from_function(self._analyze_scene, name=ANALYZE_SCENE,
                                                  scopes=list(ANALYZE_SCENE_SCOPES), timeout_s=120.0))  # fmt: skip
        self.plan = load_run_mission(settings.mission, self.registry, self.home())
        self.agent = mission_caller(self.plan, self.registry)  # the scopes this mission needs, no more
        chosen = make_reasoner(settings.reasoner, llm=settings.llm, goal=self.plan.goal)
        self._model_client = model_client(chosen)  # made from the spec here, so closed here
        self.reasoner, self.model_note = require_model(chosen)
        self.memory, self.reasoner = with_memory(self, self.reasoner)  # (None, as it was) without --memory
        self.params = {name: parse_param(self.plan, name, text) for name, text in settings.params.items()}
        self.run_dir.mkdir(parents=True, exist_ok=True)
        self.hold = self.hold or RunHold.take(self.run_dir, self.run_id, "flown")  # no resume while it flies
        keep_signing_key(self.run_dir, self.backend.signing_key)
        self.trace = TraceWriter(self.run_dir / "trace.jsonl")
        earlier = read_jsonl(self.run_dir / "trace.jsonl") if self.resuming else []
        self.trace.records.extend(earlier)
        self.bus = EventBus(clock=self.clock, first_seq=max((int(r.get("seq", 0)) for r in earlier), default=0))
        self.bus.subscribe(self._after_tool)  # first: a tool's effect is in the snapshot before it is in the trace
        self.bus.subscribe(self.trace)
        self.bus.subscribe(self._say)
        self.responses = ResponseLedger()  # critical event -> response: the outcome says whether each got one
        self.responses.replay(earlier)
        self.bus.subscribe(self.responses)
        self.telemetry = TelemetryLog(self.run_dir / "telemetry.jsonl", hz=settings.telemetry_hz)
        self.backend.on_sample(self.telemetry)
        self._world_log = (self.run_dir / "world_models.jsonl").open("a", encoding="utf-8")
        self.snapshots = SnapshotWriter(self.run_dir)
        self.links = TruthLinks(self.scene, self.bus.publish, earlier)
        self.control = ControlPort(on_command=self._on_command)
        self.failsafes = TelemetryFailsafes(self.plan.limits, self.control, self.bus.publish,
                                            texts=VehicleTexts(lambda: self._client),
                                            wall=self.backend.link_clock)  # fmt: skip
        self.backend.on_sample(self.failsafes)
        if settings.approval == "ask":
            ask: Operator = self._operator or TerminalOperator(
                sys.stdin, self.progress or sys.stderr, timeout_s=settings.approval_timeout_s
            )
            self.control.answer_with(ask)
        self.audit = JsonlAuditLog(self.run_dir / "audit.jsonl")
        self.executor = ToolExecutor(self.registry, audit=self.audit, default_caller=self.agent)
        self.faults = FaultSchedule([*(self.scene.faults if self.scene else []), *settings.faults],
                                    lambda name, args: self.executor.call(name, args, caller=SCHEDULE),
                                    self.bus.publish, delivered=(str(r.get("fault")) for r in earlier))  # fmt: skip
        self.bus.subscribe(self.faults.on_event)
        self.backend.on_sample(self.faults.on_sample)
        self.gate = Gate(self.reasoner, self._world_source(), self, self.bus.publish, self.pace,
                         on_decision=self._log_world)  # fmt: skip
        self.model = ModelSide(self.reasoner, self.plan, self.registry, self.gate, self.bus.publish, self.pace,
                               caller=self.agent)  # fmt: skip
        self.dispatch = Dispatcher(
            self.executor, run_id=self.run_id, gate=self.gate, control=self.control, pace=self.pace,
            publish=self.bus.publish, watch=self._watch, prepare={"alerts.notify": self._attachments},
            on_abort=self.plan.on_abort,
            hold_over=self._hold_over, envelope=Envelope(self.plan.limits, home=self.home, targets=self._target,
                                                         position=self._standing_at),
        )  # fmt: skip
        if self.loop is not None:  # the watch looks at every frame, in lockstep with the camera
            self.loop.on_world.append(WorldMapLog(self.run_dir / WORLD_MAP_FILE))  # what the replay's map draws
            self.loop.on_world.append(self.dispatch.spot)
            self.dispatch.frame_driven = True
        self.env = Environment(
            dispatch=self.dispatch,
            vehicle=self.view,
            world=lambda: self.loop.world if self.loop else {"objects": [], "relations": []},
            approve=None if settings.approval == "ask" else policy_approval(settings.approval == "approve",
                                                                              self.bus.publish),
            gate=self.gate,
            run_id=self.run_id,
            planner=self.model.plan if self.model.planner is not None else None,
            review=lambda steps: review(steps, self.registry, self.agent) + self.model.reads.problems(steps, self.plan)
            + destination_review(steps, self.config),
            stopping=self.dispatch.stopping,
        )  # fmt: skip

    @classmethod
    def resume(
        cls,
        runs_dir: Path,
        run_id: str,
        *,
        progress: TextIO | None = None,
        operator: Operator | None = None,
        **overrides: Any,
    ) -> MissionRun:
        """The run ``run_id`` of ``runs_dir``, ready to go on from where it was killed; ``overrides`` change its
        settings (for example ``approval``, ``speed``)."""  # fmt: skip
        record = read_record(runs_dir, run_id)
        settings = record.settings.model_copy(update={"runs_dir": runs_dir, **overrides})
        return cls(settings, progress=progress, operator=operator, run_id=record.run_id)

    # ---- what the tools, the gate and the mission read ----

    def clock(self) -> float:
        """The vehicle's clock, from its last telemetry sample (0 before the first)."""
        sample = self.last_sample
        return sample.time_s if sample is not None else self._clock0

    def view(self) -> dict[str, Any]:
        """The latest telemetry as the agent's client heard it (``vehicle`` in mission expressions)."""
        client = self._client
        return client.telemetry.model_dump() if client is not None else {}

    def _on_sample(self, sample: TelemetrySample) -> None:
        self.last_sample = sample

    def _world_source(self) -> WorldSource:
        return self.loop if self.loop is not None else NoWorld()

    def home(self) -> tuple[float, float] | None:
        """The vehicle's home as it reports it (the scene's until it has)."""
        home = self._client.home if self._client is not None else None
        if home is not None:
            return home[0], home[1]
        return (self.scene.home.lat_deg, self.scene.home.lon_deg) if self.scene is not None else None

    def _standing_at(self) -> tuple[float, float] | None:
        """Where the aircraft is now, from its telemetry (a take-off is checked against the fence from there)."""
        sample = self.last_sample
        return (sample.lat_deg, sample.lon_deg) if sample is not None else None

    def _target(self, object_id: str) -> tuple[float, float] | None:
        return self.loop.target(object_id) if self.loop else None

    async def _connect(self) -> VehicleClient:
        host, port = self.backend.address
        client = await VehicleClient.connect(f"{host}:{port}", timeout_s=10.0, signing_key=self.backend.signing_key)
        client.link_silent_s = silence_bound(self.plan.limits.link_loss_s, client.link_silent_s)
        self.backend.attach(client)
        await self.backend.raise_rates(client)
        self._client = client
        return client

    def _watch(self, state: Any) -> list[tuple[Trigger, Any]]:
        """The preempting triggers' events now, on the state the flying step started from (tier 1)."""
        found: list[tuple[Trigger, Any]] = []
        for trigger in self.plan.triggers:
            if trigger.preempt:
                found.extend((trigger, event) for event in trigger_events(trigger, state, self.env))
        return found

    def _hold_over(self, event: Any) -> dict[str, Any] | None:
        """Where to wait while the reasoner judges an event: over its object, at the altitude flown now."""
        found = object_id(event)
        altitude = self.last_sample.alt_m if self.last_sample is not None else None
        if found is None or altitude is None or self._target(found) is None:
            return None
        return {"target_id": found, "alt_m": round(max(altitude, 5.0), 1)}

    def _analyze_scene(self, focus: str | None = None, min_confidence: float = 0.5) -> dict[str, Any]:
        """Assess the scene (or one object of the world model) with the configured reasoner.

        Args:
            focus: an object id of the world model, or a description of what to look at
            min_confidence: fail when the assessment's confidence is below this, also after looking again
        """
        if self.loop is None:
            raise ToolError("no world model: this run has no scene, so there is nothing to analyse")
        decision = self.gate.confident(focus, "analyze_scene", min_confidence)
        if decision.assessment is None:
            raise ToolError(f"the reasoner failed: {decision.error}")
        low = unsure(decision, min_confidence)
        if low is not None:
            raise ToolError(
                f"confidence {low:.2f} is below the required {min_confidence:.2f}, "
                f"also after looking again for {self.gate.look_again_s:g} s"
            )
        return decision.model_dump(mode="json")

    def _log_world(self, world: WorldModel, decision: Decision) -> None:
        self.links.see(world)
        self._world_log.write(world.to_json() + "\n")
        self._world_log.flush()

    def _attachments(self, args: dict[str, Any]) -> dict[str, Any]:
        last = self.gate.last
        return materialize(
            args, out_dir=self.alerts_dir, stamp=f"{self.clock():08.1f}s", loop=self.loop, position=self._position,
            last_decision=lambda: last.model_dump(mode="json") if last else None,
        )  # fmt: skip

    def _position(self) -> dict[str, Any] | None:
        view = self.view()
        if not view:
            return None
        last = self.gate.last.assessment if self.gate.last else None
        subject = self._target(last.subject_id) if last and last.subject_id else None
        return {
            "aircraft": {k: view.get(k) for k in ("lat_deg", "lon_deg", "alt_m")},
            "subject": {"id": last.subject_id, "lat": subject[0], "lon": subject[1]} if subject and last else None,
        }

    # ---- events ----

    def _on_command(self, name: str, detail: dict[str, Any]) -> None:
        self.bus.publish("control", command=name, **detail, summary=f"{name} by {detail.get('by')}")

    def _say(self, event: RunEvent) -> None:
        if self.progress is not None and event.summary and (event.kind != "step" or "error" in event.fields()):
            sim = f"{event.sim_t:7.1f}" if event.sim_t is not None else "      -"
            print(f"[{sim} s] {event.kind}: {readable(event.summary, self.links)}", file=self.progress, flush=True)

    def _after_tool(self, event: RunEvent) -> None:
        if event.kind == "tool" and event.fields().get("status") == "ok":
            self.save_snapshot()

    def save_snapshot(self) -> None:
        """Write ``snapshot.json``: the simulated vehicle and the World Model now."""
        world = self.loop.world.model_dump(mode="json") if self.loop is not None else None
        seen, tracks = (self.loop.last_seen(), self.loop.tracker_state()) if self.loop is not None else ({}, None)
        first = dict(self.loop.first_detected) if self.loop is not None else {}
        self.snapshots.write(Snapshot(vehicle=self.backend.snapshot(), world=world, last_seen=seen, tracks=tracks,
                                      first_detected=first, sim_t=self.clock()))  # fmt: skip

    # ---- running ----

    def prepare(self) -> None:
        """Get ready before take-off: the annotator loaded (the model's connection was opened, and the model found
        answering, when the run was assembled: :func:`~agentic_core.run.model_check.require_model`)."""
        if self.loop is not None:
            self.loop.warm()

    def execute(self) -> RunResult:
        """Fly the mission (or go on with it); always releases the vehicle and writes the report
        (:func:`~agentic_core.run.fly.fly`)."""
        return fly(self)

    def where_it_ended(self) -> str:
        """Where the aircraft is now, as its telemetry says, in words (for the trace and the report)."""
        return where_it_ended(self.last_sample)

    def track(self) -> list[TrackPoint]:
        """The flight as ``telemetry.jsonl`` recorded it (every resumed part included)."""
        return [
            TrackPoint(sim_t=r["time_s"], north_m=r["north_m"], east_m=r["east_m"], alt_m=r["alt_m"], armed=r["armed"])
            for r in read_jsonl(self.run_dir / "telemetry.jsonl")
            if {"time_s", "north_m", "east_m", "alt_m"} <= r.keys()
        ]

    def close(self) -> None:
        """Release what the run holds without flying it (:meth:`execute` does this itself): the executor's workers,
        the vehicle, the open logs. Safe to call twice."""
        self.faults.close()
        self.failsafes.close()
        self.executor.close()
        self.audit.close()  # given to the executor, so not closed by it
        close_client(self._model_client)
        self.backend.close()
        self._world_log.close()
        self.telemetry.close()
        self.trace.close()
        RunHold.drop(self.hold)


def run_mission(
    settings: RunSettings,
    progress: TextIO | None = sys.stderr,
    operator: Operator | None = None,
) -> RunResult:
    """Build and fly one run (see the module docstring); raises :class:`RunError` for bad input. ``operator``
    answers approvals when ``settings.approval`` is ``ask`` (default: the terminal)."""
    return MissionRun(settings, progress=progress, operator=operator).execute()


def resume_run(
    runs_dir: Path,
    run_id: str,
    progress: TextIO | None = sys.stderr,
    operator: Operator | None = None,
    **overrides: Any,
) -> RunResult:
    """Go on with a killed run (see :meth:`MissionRun.resume`)."""  # fmt: skip
    return MissionRun.resume(runs_dir, run_id, progress=progress, operator=operator, **overrides).execute()


__all__ = [
    "AGENT",
    "MissionRun",
    "OperatorAnswer",
    "RunError",
    "RunResult",
    "RunSettings",
    "default_scene",
    "resume_run",
    "run_mission",
    "setup_frozen",
]
