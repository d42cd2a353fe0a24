"""Every long flight action a mission can be in when the operator pauses or stops it, over the fake aircraft: a
take-off, a leg, an orbit, a hover, a landing, a return and an autopilot's mission, each in the mission's own steps
and in a trigger's sub-plan. A pause, and any stop, holds the aircraft at once and ends the action interrupted;
only a stop that asks for what the action does already lets it go on (an ``rtl`` during a return, a ``land`` during
a descent). Before, a landing and a return (and every action of a sub-plan) flew on to their end, the stop unheard:
an RTL during the approved landing beside a casualty left the aircraft on the ground there."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from agentic_core.agent import AgentLoop, ControlPort, Dispatcher, Gate, LoopResult, Pace
from agentic_core.agent.loop import TIME_LIMIT
from agentic_core.graph import InMemorySaver
from agentic_core.mission import Environment, compile_mission, initial_state
from agentic_core.mission.steps import Interrupted, step_call
from tools import ToolResult

from .fakes import Aircraft, Events, FakeReasoner, FakeVehicle, FakeWorld, eventually, executor_for, wait_for
from .missions import mission

pytestmark = pytest.mark.timeout(60)

LONG = ("flight.takeoff", "flight.land", "flight.rtl", "flight.start_mission")
"""Besides fly_to, orbit and hover (long in every fake aircraft): the actions long here."""
ARGS: dict[str, dict[str, Any]] = {
    "flight.takeoff": {"altitude_m": 30.0},
    "flight.fly_to": {"north_m": 100.0, "east_m": 0.0, "alt_m": 30.0},
    "flight.orbit": {"radius_m": 20.0, "turns": 2},
    "flight.hover": {"duration_s": 60.0},
    "flight.land": {"target_id": "P-1", "offset_m": 5.0},
    "flight.rtl": {},
    "flight.start_mission": {"wait": True},
}
MISSION = {"x": 1}
SUB_PLAN = {"preempted_by": "fallen"}
COMMANDS = ("pause", "abort", "rtl", "land", "hold")
STOP_TOOL = {"rtl": "flight.rtl", "land": "flight.land", "hold": "flight.hold"}


class Telemetry:
    """The vehicle's view the dispatcher reads: ``landed_state`` as the test sets it."""

    def __init__(self, landed_state: str = "in_air") -> None:
        self.landed_state = landed_state

    def clock(self) -> float:
        return 0.0

    def view(self) -> dict[str, Any]:
        return {"alt_m": 12.0, "landed_state": self.landed_state}


class Rig:
    """A dispatcher over a fake aircraft on which every action of :data:`ARGS` flies until it arrives or a later
    command supersedes it."""

    def __init__(self, *, on_abort: Any = None, landed_state: str = "landing") -> None:
        self.aircraft = Aircraft()
        self.events = Events()
        self.pace = Pace(None)
        self.control = ControlPort()
        self.telemetry = Telemetry(landed_state)
        gate = Gate(FakeReasoner("low"), FakeWorld(), FakeVehicle(), self.events.publish, self.pace)
        self.dispatch = Dispatcher(
            executor_for(self.aircraft, long=LONG), run_id="r", gate=gate, control=self.control, pace=self.pace,
            publish=self.events.publish, poll_s=0.01, on_abort=on_abort, vehicle=self.telemetry,
        )  # fmt: skip

    @contextmanager
    def flying(self, tool: str, state: dict[str, Any]) -> Iterator[list[Any]]:
        """Dispatch ``tool`` as a step started from ``state``, on a thread; the block runs while it flies."""
        box: list[Any] = []

        def work() -> None:
            with step_call("step", state=state):
                box.append(self.dispatch(tool, dict(ARGS[tool]), None))

        thread = threading.Thread(target=work, daemon=True)
        thread.start()
        wait_for(lambda: self.aircraft.under_way() >= 1, what=f"{tool} to be under way")
        yield box
        thread.join(10)
        assert not thread.is_alive(), "the dispatch did not return"


GOES_ON = {("flight.rtl", "rtl"), ("flight.land", "land"), ("flight.rtl", "land")}
"""(action, what the stop asks) that go on during a descent: a stop asking for what the action does already."""


def goes_on(tool: str, command: str, on_abort: str | None) -> bool:
    """Whether the stop lets the action under way go on (the aircraft descending, as :class:`Rig`'s by default)."""
    return (tool, on_abort if command == "abort" else command) in GOES_ON


CASES = [
    (tool, where, command)
    for tool in ARGS
    for where in ("mission", "sub-plan")
    if not (where == "sub-plan" and tool == "flight.start_mission")
    for command in COMMANDS
]


@pytest.mark.parametrize(("tool", "where", "command"), CASES)
def test_a_pause_or_a_stop_during_a_long_action_holds_unless_the_stop_asks_for_that_action(
    tool: str, where: str, command: str
) -> None:
    rig = Rig()
    with rig.flying(tool, MISSION if where == "mission" else SUB_PLAN) as box:
        getattr(rig.control, command)()
        if goes_on(tool, command, None):
            wait_for(lambda: any("goes on" in str(s) for s in rig.events.summaries("log")), what="the action go on")
            assert not eventually(lambda: "flight.hold" in rig.aircraft.tools(), timeout_s=0.2)
            rig.aircraft.arrive()
    [outcome] = box
    if goes_on(tool, command, None):
        assert isinstance(outcome, ToolResult) and outcome.status == "ok" and outcome.output["reached"] is True
        assert rig.aircraft.tools() == [tool]
        return
    assert isinstance(outcome, Interrupted) and outcome.trigger is None
    expected = "paused by the operator" if command == "pause" else f"the operator asked to {command}"
    assert outcome.reason == expected
    assert rig.aircraft.tools() == [tool, "flight.hold"]  # held where it was, and nothing else sent
    (stopped,) = [e for e in rig.events.of("tool") if e["status"] == "interrupted"]
    assert stopped["name"] == tool and stopped["hold"] == "ok"


@pytest.mark.parametrize(
    ("by", "expected"),
    [("console", "the operator asked to rtl"), (TIME_LIMIT, "the wall-clock limit asked to rtl"),
     ("failsafe", "the failsafe asked to rtl")],
)  # fmt: skip
def test_an_interrupted_action_says_who_asked_for_the_stop(by: str, expected: str) -> None:
    """The trace and the terminal say who stopped a step: the wall-clock limit is not the operator."""
    rig = Rig()
    with rig.flying("flight.fly_to", MISSION) as box:
        rig.control.rtl(by=by)
    [outcome] = box
    assert isinstance(outcome, Interrupted) and outcome.reason == expected


@pytest.mark.parametrize("on_abort", [None, "rtl", "land", "hold"])
@pytest.mark.parametrize("tool", ["flight.land", "flight.rtl", "flight.fly_to"])
def test_an_abort_lets_go_on_only_the_action_the_missions_on_abort_names(tool: str, on_abort: str | None) -> None:
    """Ctrl-C and SIGTERM are an abort: what the mission's ``on_abort`` says, and the dispatcher knows it only when
    told (unknown, it holds, and the run's stop does what ``on_abort`` says from there)."""
    rig = Rig(on_abort=on_abort)
    with rig.flying(tool, SUB_PLAN) as box:
        rig.control.abort("SIGINT received", by="signal")
        if goes_on(tool, "abort", on_abort):
            wait_for(lambda: any("goes on" in str(s) for s in rig.events.summaries("log")), what="the action go on")
            rig.aircraft.arrive()
    [outcome] = box
    if goes_on(tool, "abort", on_abort):
        assert isinstance(outcome, ToolResult) and outcome.status == "ok" and rig.aircraft.tools() == [tool]
    else:
        assert isinstance(outcome, Interrupted) and rig.aircraft.tools() == [tool, "flight.hold"]


@pytest.mark.parametrize("tool", ["flight.land", "flight.rtl"])
def test_a_land_stop_while_the_action_still_flies_to_where_it_lands_holds_there_rather_than_fly_on(tool: str) -> None:
    """``land`` lands where the aircraft is: a landing still flying to the spot beside its target, or a return
    still flying home (not descending yet), is held, and the run's stop lands it where it holds."""
    rig = Rig(landed_state="in_air")
    with rig.flying(tool, SUB_PLAN) as box:
        rig.control.land()
    [outcome] = box
    assert isinstance(outcome, Interrupted) and rig.aircraft.tools() == [tool, "flight.hold"]


@pytest.mark.parametrize("landed_state", ["landing", "in_air"])
@pytest.mark.parametrize("action", ["rtl", "land", "hold"])
def test_a_failsafe_never_turns_back_a_landings_descent(action: str, landed_state: str) -> None:
    """A telemetry failsafe (a low battery, a lost link) during the approved landing: once descending, the landing
    goes on whatever the failsafe's action (landing is the safer one, as PX4's failsafes judge it); still flying to
    its spot, it holds as for any stop."""
    rig = Rig(landed_state=landed_state)
    with rig.flying("flight.land", SUB_PLAN) as box:
        getattr(rig.control, action)(by="failsafe")
        if landed_state == "landing":
            wait_for(lambda: any("goes on" in str(s) for s in rig.events.summaries("log")), what="the landing go on")
            rig.aircraft.arrive()
    [outcome] = box
    if landed_state == "landing":
        assert isinstance(outcome, ToolResult) and rig.aircraft.tools() == ["flight.land"]
    else:
        assert isinstance(outcome, Interrupted) and rig.aircraft.tools() == ["flight.land", "flight.hold"]


def test_a_landing_that_goes_on_leaves_the_world_at_full_speed_whatever_is_said_after() -> None:
    """Between a stop and the dispatcher's answer the simulation crawls; once the answer is to let the landing go
    on, it must not crawl until the ground (a pause after the stop changes nothing: the first stop stands)."""
    rig = Rig()
    with rig.pace.waiting("vehicle"), rig.flying("flight.land", SUB_PLAN) as box:
        rig.control.land()
        wait_for(lambda: any("goes on" in str(s) for s in rig.events.summaries("log")), what="the landing go on")
        rig.control.pause()
        assert not eventually(lambda: "flight.hold" in rig.aircraft.tools(), timeout_s=0.2)
        assert rig.pace.speed() is None
        rig.aircraft.arrive()
    assert isinstance(box[0], ToolResult) and rig.aircraft.tools() == ["flight.land"]


# ---- a mission's loop over the dispatcher: what the step does after


WAYPOINTS = """
plan_id: waypoints
goal: one leg, then home
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: wp, action: fly_to, depends_on: [up], args: {north_m: 40, east_m: 0, alt_m: 10}}
  - {id: home, action: rtl, depends_on: [wp]}
"""

RESCUE = """
plan_id: rescue
goal: land beside whoever is found, release the kit, go home
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - {id: leg, action: fly_to, depends_on: [up], args: {north_m: 100, east_m: 0, alt_m: 30}}
  - {id: home, action: rtl, depends_on: [leg]}
triggers:
  - id: fallen
    when: "find(world, class_='person')"
    steps:
      - {id: approach, action: fly_to, args: {target_id: "${event.id}", alt_m: 15}}
      - {id: land_near, action: land, depends_on: [approach], args: {target_id: "${event.id}", offset_m: 5}}
      - {id: release_kit, action: deploy_payload, depends_on: [land_near], args: {payload: rescue_kit}}
      - {id: lift_off, action: takeoff, depends_on: [release_kit], args: {altitude_m: 30}}
      - {id: back_home, action: rtl, depends_on: [lift_off]}
"""


class Flight:
    """A mission driven by the AgentLoop over :class:`Rig`'s dispatcher and aircraft (every long action flies
    until the test lets it arrive), on a thread; ``world`` is what the triggers see."""

    def __init__(self, text: str, world: dict[str, Any] | None = None) -> None:
        self.rig = Rig()
        self.plan = mission(text)
        seen = world or {"objects": [], "relations": []}
        env = Environment(self.rig.dispatch, world=lambda: seen, stopping=self.rig.dispatch.stopping)
        graph = compile_mission(self.plan, env, checkpointer=InMemorySaver())
        self.loop = AgentLoop(
            graph, {"configurable": {"thread_id": "t"}, "recursion_limit": 500}, control=self.rig.control,
            publish=self.rig.events.publish, pace=self.rig.pace, ask=False,
        )  # fmt: skip
        self.result: list[LoopResult] = []
        self.thread = threading.Thread(target=lambda: self.result.append(self.loop.run(initial_state(self.plan))))
        self.thread.daemon = True
        self.thread.start()

    def arrive_at(self, tool: str, count: int = 1) -> None:
        """Let the ``count``-th ``tool`` arrive, once it is under way."""
        aircraft = self.rig.aircraft
        wait_for(lambda: aircraft.tools().count(tool) >= count and aircraft.tools()[-1] == tool
                 and aircraft.under_way() == 1, what=f"{tool} #{count} under way")  # fmt: skip
        aircraft.arrive()

    def under_way(self, tool: str, count: int = 1) -> None:
        aircraft = self.rig.aircraft
        wait_for(lambda: aircraft.tools().count(tool) >= count and aircraft.under_way() == 1, what=f"{tool} flying")

    def finish(self) -> LoopResult:
        self.thread.join(20)
        assert not self.thread.is_alive(), "the loop did not end"
        return self.result[0]


def test_a_pause_during_the_missions_return_holds_it_and_resume_flies_the_return_again() -> None:
    flight = Flight(WAYPOINTS)
    flight.arrive_at("flight.takeoff")
    flight.arrive_at("flight.fly_to")
    flight.under_way("flight.rtl")
    flight.rig.control.pause()
    wait_for(lambda: "paused: holding until resumed" in flight.rig.events.summaries("log"), what="the loop to hold")
    assert flight.rig.aircraft.tools()[-2:] == ["flight.rtl", "flight.hold"]
    assert not eventually(lambda: flight.rig.aircraft.tools()[-1] != "flight.hold", timeout_s=0.2)  # it holds
    flight.rig.control.resume()
    flight.arrive_at("flight.rtl", 2)  # the interrupted step runs again, from where the aircraft holds
    result = flight.finish()
    assert result.stopped is None and result.state["status"]["home"] == "ok"
    assert flight.rig.aircraft.tools() == ["flight.takeoff", "flight.fly_to", "flight.rtl", "flight.hold", "flight.rtl"]


PERSON = {"objects": [{"id": "P-1", "class": "person"}], "relations": []}


@pytest.mark.parametrize("command", ["rtl", "abort"])
def test_a_stop_during_the_sub_plans_landing_holds_it_and_no_kit_is_released(command: str) -> None:
    """The emergency mission's approved landing beside a casualty: an RTL or an abort (Ctrl-C) ends it held in
    the air, the loop stops with it, and neither the kit nor anything after is sent (the run's stop then flies
    home from where it holds)."""
    flight = Flight(RESCUE, world=PERSON)
    flight.arrive_at("flight.takeoff")
    flight.arrive_at("flight.fly_to")  # the approach: the trigger fired as the leg was to start
    flight.under_way("flight.land")
    getattr(flight.rig.control, command)()
    result = flight.finish()
    assert result.stopped == command
    assert flight.rig.aircraft.tools() == ["flight.takeoff", "flight.fly_to", "flight.land", "flight.hold"]
    assert result.state["status"]["land_near"] != "ok" and "release_kit" not in flight.rig.aircraft.tools()


def test_a_land_stop_during_the_sub_plans_descent_lets_it_land_and_nothing_follows() -> None:
    flight = Flight(RESCUE, world=PERSON)
    flight.arrive_at("flight.takeoff")
    flight.arrive_at("flight.fly_to")
    flight.under_way("flight.land")
    flight.rig.control.land()
    wait_for(lambda: any("goes on" in str(s) for s in flight.rig.events.summaries("log")), what="the landing go on")
    flight.rig.aircraft.arrive()
    result = flight.finish()
    assert result.stopped == "land" and result.state["status"]["land_near"] == "ok"
    assert flight.rig.aircraft.tools() == ["flight.takeoff", "flight.fly_to", "flight.land"]  # no kit, no lift-off
