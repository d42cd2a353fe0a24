"""Small stand-ins for what the agent is plugged into: a World Model source, a vehicle clock, a reasoner returning
Decisions, an aircraft behind fake ``flight.*`` tools, an event recorder, and ``wait_for`` (a bounded wait on a
condition, never a fixed sleep)."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from typing import Any

from agentic_core.contracts import RunEvent
from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.assessment import Assessment, Decision
from tools import ToolExecutor, ToolRegistry, ToolSpec

LAT, LON = 21.4133, 39.8933
WAIT_S = 10.0  # the longest any condition is waited for


def wait_for(condition: Callable[[], bool], timeout_s: float = WAIT_S, what: str = "the condition") -> None:
    """Return once ``condition()`` holds; fail the test after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")
        time.sleep(0.002)


def eventually(condition: Callable[[], bool], timeout_s: float) -> bool:
    """Whether ``condition()`` comes to hold within ``timeout_s`` (for what a correct implementation never does:
    the wait is the chance given to the wrong behaviour to show)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


def person(object_id: str, state: str = "confirmed", stationary_s: float = 12.0) -> dict[str, Any]:
    pose = {"north": 0, "east": 0, "down": 0, "lat": LAT, "lon": LON, "alt": 300}
    return {"id": object_id, "class": "person", "pose": pose, "conf": 0.7, "state": state, "stationary_s": stationary_s}


def world_of(*objects: dict[str, Any], timestamp: float = 60.0) -> WorldModel:
    ego = {"north": 0, "east": 0, "down": -15, "lat": LAT, "lon": LON, "alt": 315}
    return WorldModel.model_validate({"timestamp": timestamp, "ego_pose": ego, "objects": list(objects)})


class FakeWorld:
    """A WorldSource: the World Model the test sets, object positions, and re-identifications (old id -> new)."""

    def __init__(self, world: WorldModel | None = None, renamed: dict[str, str] | None = None) -> None:
        self._lock = threading.Lock()
        self._world = world if world is not None else world_of()
        self.renamed = dict(renamed or {})
        self.reads = 0
        self.on_read: Callable[[], None] | None = None

    @property
    def world(self) -> WorldModel:
        if self.on_read is not None:
            self.on_read()
        with self._lock:
            self.reads += 1
            return self._world

    def set(self, world: WorldModel) -> None:
        with self._lock:
            self._world = world

    def target(self, object_id: str) -> tuple[float, float] | None:
        return (LAT, LON) if self.world.get(object_id) is not None else None

    def resolve(self, object_id: str) -> str | None:
        if object_id in self.renamed:
            return self.renamed[object_id]
        return object_id if self.world.get(object_id) is not None else None


class FakeVehicle:
    """A VehicleView whose clock the test moves (``advance``), or which moves by ``step_s`` at every read."""

    def __init__(self, start: float = 100.0, step_s: float = 0.0) -> None:
        self._lock = threading.Lock()
        self._now = start
        self.step_s = step_s

    def clock(self) -> float:
        with self._lock:
            self._now += self.step_s
            return self._now

    def advance(self, seconds: float) -> None:
        with self._lock:
            self._now += seconds

    def view(self) -> dict[str, Any]:
        return {"alt_m": 30.0, "landed_state": "in_air"}


def decision(severity: str | None, subject: str | None = None) -> Decision:
    """A Decision of that severity (None: the reasoner failed)."""
    if severity is None:
        return Decision(reasoner="fake", assessment=None, processing_time_s=0.0, error="the model did not answer")
    assessment = Assessment(persons_detected=1, confidence=0.9, severity=severity, subject_id=subject)
    return Decision(reasoner="fake", assessment=assessment, processing_time_s=0.0)


class FakeReasoner:
    """A ReasonerPort answering ``severity`` (or per focus from ``by_focus``); records each call's focus and world.
    ``during`` runs inside each call (to look at pacing, or to hold the reasoner until the test lets it go)."""

    name = "fake"

    def __init__(
        self,
        severity: str | None = "critical",
        by_focus: dict[str, str | None] | None = None,
        during: Callable[[str | None], None] | None = None,
    ) -> None:
        self.severity = severity
        self.by_focus = dict(by_focus or {})
        self.during = during
        self.calls: list[tuple[str | None, WorldModel]] = []
        self._lock = threading.Lock()

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        with self._lock:
            self.calls.append((focus, world))
        if self.during is not None:
            self.during(focus)
        severity = self.by_focus.get(focus, self.severity) if focus is not None else self.severity
        return decision(severity, focus)

    def foci(self) -> list[str | None]:
        with self._lock:
            return [focus for focus, _ in self.calls]


class Unsure:
    """A ReasonerPort judging its focus critical, counting ``persons`` at the confidences given, in turn (the last
    repeats); ``at`` has the vehicle's clock at each call (None without a vehicle)."""

    name = "unsure"

    def __init__(self, confidences: list[float], vehicle: FakeVehicle | None = None, persons: int = 1) -> None:
        self.confidences = confidences
        self.vehicle = vehicle
        self.persons = persons
        self.at: list[float | None] = []

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        self.at.append(self.vehicle.clock() if self.vehicle is not None else None)
        confidence = self.confidences[min(len(self.at), len(self.confidences)) - 1]
        assessment = Assessment(persons_detected=self.persons, confidence=confidence, severity="critical",
                                subject_id=focus)  # fmt: skip
        return Decision(reasoner=self.name, assessment=assessment, processing_time_s=0.0)


class Events:
    """A bus stand-in (``publish``) and subscriber: keeps every event in order, thread-safe."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.events: list[RunEvent] = []

    def __call__(self, event: RunEvent) -> None:
        with self._lock:
            self.events.append(event)

    def publish(self, kind: str, /, **fields: Any) -> RunEvent:
        with self._lock:
            event = RunEvent(kind=kind, seq=len(self.events) + 1, **fields)
            self.events.append(event)
        return event

    def of(self, kind: str) -> list[dict[str, Any]]:
        with self._lock:
            return [{"summary": e.summary, **e.fields()} for e in self.events if e.kind == kind]

    def summaries(self, kind: str) -> list[str | None]:
        return [e["summary"] for e in self.of(kind)]


class Aircraft:
    """The fake vehicle behind ``flight.*`` tools: ``flight.fly_to`` flies until the test calls :meth:`arrive` or a
    later command (``flight.hold``, another ``fly_to``) supersedes it; every other tool answers at once. Each
    command is recorded with the tool's name and arguments. ``instant`` makes every fly_to arrive at once."""

    def __init__(self, *, instant: bool = False) -> None:
        self._cond = threading.Condition()
        self.commands: list[tuple[str, dict[str, Any]]] = []
        self.arrived = 0  # commands up to this index have arrived
        self.flying = 0  # fly_to calls under way
        self.instant = instant
        self.on_command: Callable[[str, dict[str, Any]], None] | None = None

    def command(self, tool: str, args: dict[str, Any]) -> int:
        if self.on_command is not None:
            self.on_command(tool, args)
        with self._cond:
            self.commands.append((tool, dict(args)))
            self._cond.notify_all()
            return len(self.commands)

    def fly_to(self, args: dict[str, Any]) -> dict[str, Any]:
        return self.flies("flight.fly_to")(args)

    def flies(self, tool: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
        """A long flight action: under way until it arrives or a later command supersedes it."""

        def act(args: dict[str, Any]) -> dict[str, Any]:
            mine = self.command(tool, args)
            with self._cond:
                self.flying += 1
                try:
                    done = self._cond.wait_for(
                        lambda: self.instant or self.arrived >= mine or len(self.commands) > mine, timeout=WAIT_S
                    )
                    reached = done and (self.instant or self.arrived >= mine)
                    return {"reached": reached, "superseded": len(self.commands) > mine}
                finally:
                    self.flying -= 1

        return act

    def other(self, tool: str) -> Callable[[dict[str, Any]], dict[str, Any]]:
        def act(args: dict[str, Any]) -> dict[str, Any]:
            self.command(tool, args)
            return {"done": tool}

        return act

    def arrive(self) -> None:
        """The fly_to under way (the last command) arrives."""
        with self._cond:
            self.arrived = len(self.commands)
            self._cond.notify_all()

    def tools(self) -> list[str]:
        with self._cond:
            return [tool for tool, _ in self.commands]

    def sent(self, tool: str) -> list[dict[str, Any]]:
        with self._cond:
            return [args for name, args in self.commands if name == tool]

    def under_way(self) -> int:
        with self._cond:
            return self.flying


FLIGHT_TOOLS = ("flight.takeoff", "flight.hold", "flight.land", "flight.rtl", "flight.deploy_payload")


def registry_for(
    aircraft: Aircraft,
    extra: Iterable[tuple[str, Callable[[dict[str, Any]], Any]]] = (),
    long: Iterable[str] = (),
) -> ToolRegistry:
    """A real registry with the aircraft's ``flight.*`` tools, ``alerts.notify``, ``perception.analyze_scene`` and
    ``extra`` tools (any arguments, no retries); the tools named in ``long`` fly until they arrive, as ``fly_to``."""
    registry = ToolRegistry()
    flying = ("flight.fly_to", "flight.orbit", "flight.hover", *long)
    tools: list[tuple[str, Callable[[dict[str, Any]], Any]]] = [(name, aircraft.flies(name)) for name in flying]
    tools += [(name, aircraft.other(name)) for name in (*FLIGHT_TOOLS, "flight.start_mission") if name not in flying]
    tools += [("alerts.notify", lambda args: {"sent": True}), ("perception.analyze_scene", lambda args: {"ok": True})]
    for name, handler in [*tools, *extra]:
        registry.register(ToolSpec.from_schema(name, handler, {"type": "object"}, timeout_s=2 * WAIT_S))
    return registry


def executor_for(
    aircraft: Aircraft, extra: dict[str, Callable[[dict[str, Any]], Any]] | None = None, long: Iterable[str] = ()
) -> ToolExecutor:
    return ToolExecutor(registry_for(aircraft, (extra or {}).items(), long))
