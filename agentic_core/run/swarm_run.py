"""``agentic-uav swarm run MISSION --vehicles N``: a swarm mission flown by N UAVs, each with its own agent loop.

Each UAV is a :class:`~agentic_core.run.runner.MissionRun` of its share of the mission
(:func:`~agentic_core.swarm.projection.project`), on its own thread (``uav-<n>``), seated in the swarm
(:class:`SwarmSeat`): the simulated vehicles tick together on one clock (:class:`~flight.mavlink.lockstep.Lockstep`,
thread ``swarm-clock``) at the pace of all the agents at once (one :class:`~agentic_core.agent.pacing.Pace`), or,
with ``--connect``, each UAV flies the vehicle at its address. The ground side
(:class:`~agentic_core.swarm.coordinator.SwarmCoordinator`) auctions the sectors by Contract Net before take-off and
the casualty work as it comes, over signed messages posted over HTTP to each UAV's A2A server (127.0.0.1, a free
port; its signed Agent Card says its live state); the caller's thread watches the members (a dead one's tasks
move) until every UAV's run has ended. With ``--fault ground_link@t=N`` the ground is lost at N s of the swarm's
clock: from then on the UAVs allocate among themselves by consensus
(:meth:`~agentic_core.swarm.coordinator.SwarmCoordinator.lose_ground`).

Files: ``runs/<swarm-id>/`` holds ``swarm.jsonl`` (rounds, awards, claims, verifications, deliveries, failures),
``refusals.jsonl`` (swarm messages refused, audited), ``summary.json`` and ``report.md``, ``missions/uav-<n>.yaml``
(each UAV's share), and one run directory per UAV (its own trace, telemetry, audit, report).
"""

from __future__ import annotations

import json
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, TextIO, cast

import yaml

from flight.mavlink.lockstep import Lockstep
from flight.signing import read_key_file
from flight.sim.environment import Home
from tools import ToolRegistry

from ..agent.control import Operator
from ..agent.pacing import Pace
from ..contracts import TelemetrySample
from ..contracts.geodesy import offset_position
from ..contracts.policy_graph import PolicyGraph
from ..contracts.swarm import Point, Rejection, UavState
from ..mission.source import MissionError
from ..mission.validate import load_mission
from ..swarm.coordinator import Member, SwarmCoordinator
from ..swarm.fleet_tools import register_swarm_tools
from ..swarm.leg_gate import gate_legs
from ..swarm.operator_verify import Verdict
from ..swarm.projection import project
from ..swarm.sectors import split
from ..swarm.separation import GRID_S, SeparationLog
from ..swarm.signing import JsonlAudit, MemoryAudit, SwarmKey
from .backends import Backend
from .runner import MissionRun
from .settings import RunError, RunResult, RunSettings, default_scene
from .swarm_airspace import swarm_airspace
from .swarm_backend import LockstepBackend
from .swarm_connect import ConnectedBackend, find_fleet
from .swarm_operator import SharedTerminal, ask_on_port
from .swarm_outcome import outcome_of, write_summary

MONITOR_S = 0.2
"""How often (wall) the caller's thread checks the members."""


@dataclass
class SwarmSettings:
    """Everything ``agentic-uav swarm run`` is told."""

    mission: Path
    vehicles: int | None = None
    connect: list[str] = field(default_factory=list)
    signing_key: Path | None = None
    """With ``connect``: the MAVLink 2 signing key file every UAV's link is signed with (one key for all)."""
    scene: Path | None = None
    runs_dir: Path = Path("runs")
    speed: float | None = None
    seed: int = 0
    reasoner: str = "rules"
    gcs: str = "none"
    px4_ports: bool = False
    max_wall_s: float = 900.0
    rounds: int | None = None
    camera_hz: float = 10.0
    """Each UAV's camera: fewer frames than one drone's 30, for N perception loops on one machine."""
    ground_link_lost_s: float | None = None
    """``--fault ground_link@t=N``: the swarm's clock time the ground link is lost (then consensus among the UAVs)."""
    a2a: bool = True
    """Each UAV an A2A agent on 127.0.0.1, the Contract Net over HTTP; False: in-process (the same guards)."""
    approval: Literal["approve", "decline", "ask"] | None = None
    """Each UAV's approvals (and the operator's verification): None asks the operator when the mission's
    ``verify`` is ``by: operator``, and approves otherwise."""
    operator: Operator | None = None
    """With ``approval="ask"``: who answers (a script); None: the terminal."""


class _Audit:
    """Refusals to ``refusals.jsonl`` and kept in memory for the summary."""

    def __init__(self, path: Path) -> None:
        self.file = JsonlAudit(path)
        self.memory = MemoryAudit()

    def record(self, rejection: Rejection) -> None:
        self.file.record(rejection)
        self.memory.record(rejection)


class SwarmSeat:
    """One UAV's seat (:class:`~agentic_core.run.fleet_seat.FleetSeat`)."""

    def __init__(self, swarm: SwarmRun, index: int) -> None:
        self.swarm = swarm
        self.index = index
        self.uav = swarm.fleet[index].uav if swarm.fleet else f"uav-{index + 1}"
        self.system_id = swarm.fleet[index].system_id if swarm.fleet else index + 1
        self.pace = swarm.pace
        self.run: MissionRun | None = None
        self.result: RunResult | None = None
        self.error: str | None = None
        self.thread: threading.Thread | None = None

    def backend(self, run: Any) -> Backend:
        swarm, settings = self.swarm, self.swarm.settings
        if settings.connect:
            return ConnectedBackend(swarm.fleet[self.index], camera_hz=settings.camera_hz,
                                    tlog=run.run_dir / "flight.tlog", signing_key=swarm.signing_key)  # fmt: skip
        return LockstepBackend(
            clock=swarm.clock, index=self.index, home=swarm.home, pad_east_m=swarm.pad_east(self.index),
            px4_ports=settings.px4_ports, seed=settings.seed + self.index, pace=self.pace,
            gcs=run.settings.gcs_address, tlog=run.run_dir / "flight.tlog",
        )  # fmt: skip

    def tools(self, registry: ToolRegistry, run: Any) -> None:
        margin = self.swarm.plan_swarm.separation.horizontal_m + 5.0
        register_swarm_tools(registry, self.swarm.coordinator, self.uav, wait=self.swarm.wait, separation_m=margin)
        home, pad = self.swarm.home, Point(north=0.0, east=self.swarm.pad_east(self.index))
        gate_legs(registry, self.swarm.coordinator.legs, self.uav, here=lambda: self.state().position,
                  origin=(home.lat_deg, home.lon_deg), pad=pad, targets=run._target)  # fmt: skip

    # ---- what the coordinator reads ----

    def state(self) -> UavState:
        sample = self.run.last_sample if self.run is not None else None
        payload = self.swarm.plan_swarm.payload_of(self.index)
        status = "idle" if self.alive() else "failed"
        if sample is None:
            north, east = self.swarm.start_of(self.index)
            where = Point(north=north, east=east, alt=0.0)
            return UavState(uav_id=self.uav, position=where, battery_pct=100.0, payload=payload, status=status)
        where = Point(north=sample.north_m, east=sample.east_m, alt=sample.alt_m)
        battery = min(100.0, max(0.0, sample.battery_pct if sample.battery_pct is not None else 100.0))
        return UavState(uav_id=self.uav, position=where, battery_pct=battery, payload=payload, status=status)

    def ask(self, request: dict[str, Any], timeout_s: float) -> Verdict:
        """Ask this UAV's operator (:func:`~agentic_core.run.swarm_operator.ask_on_port`); silence before it flies."""
        return ask_on_port(self.run, request, timeout_s) if self.run is not None else "no_answer"

    def world(self) -> Any:
        loop = self.run.loop if self.run is not None else None
        return loop.world if loop is not None else None

    def alive(self) -> bool:
        if self.error is not None:
            return False
        if self.result is not None:
            return self.result.summary.outcome in ("completed", "returned", "degraded")
        backend = self.run.backend if self.run is not None else None
        return not isinstance(backend, LockstepBackend) or backend.alive

    def on_sample(self, sample: TelemetrySample) -> None:
        if sample.armed and sample.alt_m > 1.0:
            where = Point(north=sample.north_m, east=sample.east_m, alt=sample.alt_m)
            # connected vehicles each count from their own boot: they share the swarm's clock, on the log's grid
            at = round(self.swarm.time_s() / GRID_S) * GRID_S if self.swarm.fleet else sample.time_s
            self.swarm.separation.record(self.uav, at, where)
        self.swarm.coordinator.heartbeats.beat(self.uav)  # its own signed word that it lives, once the ground is lost

    def fly(self) -> None:
        assert self.run is not None
        try:
            self.result = self.run.execute()
        except Exception as exc:  # one UAV's crash is the swarm's news, not the end of the others
            self.error = f"{type(exc).__name__}: {exc}"
        finally:
            self.swarm.coordinator.legs.release(self.uav, "its run ended")


class SwarmRun:
    """One swarm run, assembled (see the module docstring); :meth:`execute` flies it."""

    def __init__(self, settings: SwarmSettings, *, progress: TextIO | None = None) -> None:
        self.settings = settings
        self.progress = progress
        try:
            plan = load_mission(settings.mission)
        except MissionError as exc:
            raise RunError(str(exc)) from None
        if plan.swarm is None:
            raise RunError(f"{settings.mission}: not a swarm mission (it has no swarm: block)")
        self.plan: PolicyGraph = plan
        self.approval = settings.approval or ("ask" if plan.swarm.verify.by == "operator" else "approve")
        self.plan_swarm = plan.swarm
        n = len(settings.connect) or settings.vehicles or plan.swarm.vehicles
        if settings.connect and settings.vehicles not in (None, n):
            raise RunError(f"--vehicles {settings.vehicles} but --connect names {n} vehicles")
        self.n = n
        scene = settings.scene or default_scene(settings.mission)
        self.scene_path = scene
        self.home = self._home(scene)
        if settings.signing_key is not None and not settings.connect:
            raise RunError("--signing-key goes with --connect (it signs the links to vehicles of their own)")
        self.signing_key = read_key_file(settings.signing_key) if settings.signing_key is not None else None
        self.fleet = find_fleet(settings.connect, self.home, [(c.lat, c.lon) for c in plan.swarm.area],
                                signing_key=self.signing_key) if settings.connect else []  # fmt: skip
        self.swarm_id = f"{time.strftime('%Y%m%d-%H%M%S')}-{settings.mission.stem}-swarm"
        self.dir = settings.runs_dir / self.swarm_id
        (self.dir / "missions").mkdir(parents=True, exist_ok=True)
        self.pace = Pace(settings.speed)
        self.clock = Lockstep()
        self._t0 = time.monotonic()
        self.separation = SeparationLog(
            horizontal_m=plan.swarm.separation.horizontal_m, vertical_m=plan.swarm.separation.vertical_m
        )
        self.audit = _Audit(self.dir / "refusals.jsonl")
        self._log_lock = threading.Lock()
        self.seats = [SwarmSeat(self, i) for i in range(n)]
        sectors = split([(c.lat, c.lon) for c in plan.swarm.area], n, home=(self.home.lat_deg, self.home.lon_deg))
        declared = plan.params.get("rounds")
        rounds = settings.rounds or int(declared.default if declared is not None and declared.default else 1)
        self.coordinator = SwarmCoordinator(
            SwarmKey.generate(plan.plan_id), [self._member(s) for s in self.seats], sectors, rounds=rounds,
            verify_k=min(plan.swarm.verify.k, n), verification=plan.swarm.verify, audit=self.audit,
            heartbeat=plan.swarm.heartbeat, log=self._log, clock=self.time_s,
            a2a=settings.a2a, airspace=swarm_airspace(plan.swarm),
        )  # fmt: skip
        self.sectors = sectors
        terminal = SharedTerminal(
            sys.stdin, sys.stderr, timeout_s=RunSettings.model_fields["approval_timeout_s"].default
        )
        try:
            for seat in self.seats:
                said = cast(TextIO, _Prefixed(progress, seat.uav)) if progress is not None else None
                operator = settings.operator or terminal.for_uav(seat.uav)  # one terminal, not one reader per UAV
                seat.run = MissionRun(self._settings_of(seat), progress=said, fleet=seat, operator=operator)
                seat.run.backend.on_sample(seat.on_sample)
        except Exception:
            self.close()
            raise

    def _home(self, scene: Path | None) -> Home:
        if scene is None:
            return Home()
        from .assembly import load_run_scene

        return load_run_scene(scene).home.to_home()

    def time_s(self) -> float:
        """The swarm's clock: the simulated one, or (vehicles of their own, ``--connect``) seconds since the start."""
        return time.monotonic() - self._t0 if self.settings.connect else self.clock.time_s

    def pad_east(self, index: int) -> float:
        """Where UAV ``index``'s pad is, metres east of the scene's home (the pads in a row, centred on it)."""
        return (index - (self.n - 1) / 2) * self.plan_swarm.pad_spacing_m

    def start_of(self, index: int) -> tuple[float, float]:
        """Where UAV ``index`` starts, north and east of the scene's home: its pad, or a connected vehicle's home."""
        if self.fleet:
            return self.fleet[index].north_m, self.fleet[index].east_m
        return 0.0, self.pad_east(index)

    def _member(self, seat: SwarmSeat) -> Member:
        layers = self.plan_swarm.layers_m
        park = offset_position(self.home.lat_deg, self.home.lon_deg, *self.start_of(seat.index))
        layer = layers[seat.index % len(layers)]
        return Member(seat.uav, seat.state, layer, world=seat.world, alive=seat.alive, park=park, ask=seat.ask)

    def _settings_of(self, seat: SwarmSeat) -> RunSettings:
        raw = yaml.safe_load(self.settings.mission.read_text(encoding="utf-8"))
        layer = self.plan_swarm.layers_m[seat.index % len(self.plan_swarm.layers_m)]
        role = self.plan_swarm.role_of(seat.index)
        mine = project(raw, role=role, params={"layer_m": layer, "uav": seat.uav, "role": role or ""})
        path = self.dir / "missions" / f"{seat.uav}.yaml"
        path.write_text(yaml.safe_dump(mine, sort_keys=False, allow_unicode=True), encoding="utf-8")
        return RunSettings(
            mission=path, scene=self.scene_path, reasoner=self.settings.reasoner, speed=self.settings.speed,
            runs_dir=self.dir, seed=self.settings.seed + seat.index, gcs=self.settings.gcs,
            max_wall_s=self.settings.max_wall_s, camera_hz=self.settings.camera_hz, approval=self.approval,
        )  # fmt: skip

    def _log(self, record: dict[str, Any]) -> None:
        with self._log_lock, (self.dir / "swarm.jsonl").open("a", encoding="utf-8") as out:
            out.write(json.dumps(record, default=str) + "\n")
        if self.progress is not None:
            shown = {k: v for k, v in record.items() if k not in ("t", "event", "sim_t")}
            print(f"[{record['sim_t']:7.1f} s] swarm {record['event']}: {shown}", file=self.progress, flush=True)

    def wait(self) -> None:
        """A pause between looks while a tool awaits the swarm (wall time; the clock runs meanwhile)."""
        time.sleep(0.02)

    def kill(self, uav: str) -> None:
        """Kill one UAV's vehicle mid-flight (a crash: its link and its aircraft gone); the swarm must cope."""
        seat = next(s for s in self.seats if s.uav == uav)
        if seat.run is not None:
            seat.run.backend.close()

    def execute(self) -> dict[str, Any]:
        """Fly the swarm: sectors auctioned, every UAV's run on its thread, the members watched; the summary."""
        wall0 = time.monotonic()
        try:
            self._log({"event": "a2a", "sim_t": 0.0, "t": time.time(), "agents": self.coordinator.agents()})
            awarded = self.coordinator.allocate_sectors()
            self._log({"event": "sectors", "sim_t": 0.0, "t": time.time(), "awarded": awarded,
                       "sectors": {s.id: s.corners() for s in self.sectors}})  # fmt: skip
            if not self.settings.connect:
                self.clock.start(self.pace.speed)
            for seat in self.seats:
                seat.thread = threading.Thread(target=seat.fly, name=seat.uav, daemon=True)
                seat.thread.start()
            while any(s.thread is not None and s.thread.is_alive() for s in self.seats):
                lost_s = self.settings.ground_link_lost_s
                if lost_s is not None and self.time_s() >= lost_s:
                    self.coordinator.lose_ground(f"fault ground_link@t={lost_s:g}s")
                self.coordinator.watch()
                if time.monotonic() - wall0 > self.settings.max_wall_s + 60:
                    break
                time.sleep(MONITOR_S)
            self.coordinator.watch()
        finally:
            self.close()
        summary = outcome_of(self, time.monotonic() - wall0)
        write_summary(self.dir, summary)
        return summary

    def close(self) -> None:
        """Stop the clock and the manager; close every UAV's run that is not flying (idempotent)."""
        self.clock.stop()
        self.coordinator.close()
        for seat in self.seats:
            if seat.run is not None and (seat.thread is None or not seat.thread.is_alive()) and seat.result is None:
                seat.run.close()


class _Prefixed:
    """A progress stream whose lines name the UAV."""

    def __init__(self, out: TextIO, uav: str) -> None:
        self.out = out
        self.uav = uav

    def write(self, text: str) -> int:
        self.out.write(f"{self.uav} {text}" if text.strip() else text)
        return len(text)

    def flush(self) -> None:
        self.out.flush()


def run_swarm(settings: SwarmSettings, progress: TextIO | None = None) -> dict[str, Any]:
    """Build and fly a swarm run; its summary (``outcome``, ``exit``, ...)."""
    return SwarmRun(settings, progress=progress).execute()


__all__ = ["SwarmRun", "SwarmSeat", "SwarmSettings", "run_swarm"]
