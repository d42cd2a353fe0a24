"""The dispatcher's watch during a long flight action (a fake ``flight.fly_to`` that flies until the test lets it
arrive or a later command supersedes it): a new event judged and acted on, or declined and flown on; a known event
left alone; pause and stop commands; a trigger's own sub-plan not watched; holding over the object meanwhile."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from agentic_core.agent import ControlPort, Dispatcher, Gate, Pace
from agentic_core.agent.pacing import URGENT_SPEED
from agentic_core.mission.model import Trigger
from agentic_core.mission.steps import Interrupted, step_call
from tools import ToolResult

from .fakes import (
    Aircraft,
    Events,
    FakeReasoner,
    FakeVehicle,
    FakeWorld,
    eventually,
    executor_for,
    person,
    wait_for,
    world_of,
)
from .missions import WATCHED, trigger
from .stand_ins import KeyedExecutor

pytestmark = pytest.mark.timeout(60)

LEG = {"north_m": 100.0, "east_m": 0.0, "alt_m": 30.0}
FALLEN = trigger("fallen", WATCHED)


class Rig:
    """A dispatcher over the fake aircraft, with a watch the test sets (the events its rule finds now)."""

    def __init__(self, severity: str | None = "critical", **options: Any) -> None:
        self.aircraft = Aircraft()
        self.events = Events()
        self.pace = Pace(None)
        self.control = ControlPort()
        self.found: list[tuple[Trigger, Any]] = []
        self.watched: list[Any] = []
        self.reasoner = options.pop("reasoner", None) or FakeReasoner(severity)
        world = FakeWorld(world_of(person("P-1"), person("P-2")))
        self.gate = Gate(self.reasoner, world, FakeVehicle(), self.events.publish, self.pace)
        self.executor = options.pop("executor", None) or executor_for(self.aircraft)
        self.dispatch = Dispatcher(
            self.executor, run_id="r", gate=self.gate, control=self.control, pace=self.pace,
            publish=self.events.publish, watch=self.watch, poll_s=0.01, **options,
        )  # fmt: skip

    def watch(self, state: Any) -> list[tuple[Trigger, Any]]:
        self.watched.append(state)
        return list(self.found)

    @contextmanager
    def flying(
        self, state: dict[str, Any] | None = None, args: dict[str, Any] = LEG, tool: str = "flight.fly_to"
    ) -> Iterator[list[Any]]:
        """Dispatch ``flight.fly_to`` as mission step ``leg`` on a thread; the block runs while it flies; the list
        holds its outcome after the block."""
        box: list[Any] = []

        def work() -> None:
            with step_call("leg", state={} if state is None else state):
                box.append(self.dispatch(tool, dict(args), None))

        thread = threading.Thread(target=work, daemon=True)
        thread.start()
        wait_for(lambda: self.aircraft.under_way() >= 1, what="the leg to be flying")
        yield box
        thread.join(10)
        assert not thread.is_alive(), "the dispatch did not return"

    def tool_statuses(self) -> list[tuple[str, str]]:
        return [(e["name"], e["status"]) for e in self.events.of("tool")]


def test_a_new_event_that_the_reasoner_lets_act_interrupts_the_leg_and_holds() -> None:
    rig = Rig("critical")
    event = {"id": "P-1", "stationary_s": 6.0}
    with rig.flying() as box:
        rig.found.append((FALLEN, event))
    [outcome] = box
    assert isinstance(outcome, Interrupted)
    assert outcome.trigger == "fallen" and outcome.event == event and "fallen acts on P-1" in outcome.reason
    assert rig.aircraft.tools() == ["flight.fly_to", "flight.hold"]
    assert rig.reasoner.foci() == ["P-1"]
    interrupted = [e for e in rig.events.of("tool") if e["status"] == "interrupted"]
    assert len(interrupted) == 1 and interrupted[0]["trigger"] == "fallen" and interrupted[0]["hold"] == "ok"
    assert rig.events.events[-1].kind == "tool"  # the interruption is the last thing published


def test_a_declined_event_sends_the_leg_again_and_the_call_returns_its_real_result() -> None:
    rig = Rig("low")
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1"}))
        wait_for(lambda: rig.aircraft.tools().count("flight.fly_to") == 2, what="the leg sent again")
        wait_for(lambda: rig.aircraft.under_way() == 1, what="the first leg to end")
        rig.aircraft.arrive()
    [outcome] = box
    assert isinstance(outcome, ToolResult) and outcome.status == "ok" and outcome.output["reached"] is True
    assert rig.aircraft.tools() == ["flight.fly_to", "flight.hold", "flight.fly_to"]
    assert rig.aircraft.sent("flight.fly_to") == [LEG, LEG]
    assert rig.reasoner.foci() == ["P-1"]  # judged once, although the rule kept holding
    assert ("flight.fly_to", "resumed") in rig.tool_statuses()
    assert rig.events.of("trigger")[0]["act"] is False


def test_a_known_event_is_not_judged_again() -> None:
    rig = Rig("low")
    rig.gate(FALLEN, {"id": "P-1"})  # judged at a barrier before the leg
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1", "stationary_s": 30.0}))
        count = len(rig.watched)
        wait_for(lambda: len(rig.watched) > count + 3, what="the watch to look a few times")
        rig.aircraft.arrive()
    [outcome] = box
    assert isinstance(outcome, ToolResult) and outcome.status == "ok"
    assert rig.aircraft.tools() == ["flight.fly_to"] and rig.reasoner.foci() == ["P-1"]


def test_a_second_new_event_during_a_flown_on_leg_is_judged_too() -> None:
    rig = Rig(reasoner=FakeReasoner(by_focus={"P-1": "low", "P-2": "high"}))
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1"}))
        wait_for(lambda: rig.aircraft.tools().count("flight.fly_to") == 2, what="the leg sent again")
        rig.found.append((FALLEN, {"id": "P-2"}))
    [outcome] = box
    assert isinstance(outcome, Interrupted) and outcome.event == {"id": "P-2"}
    assert rig.reasoner.foci() == ["P-1", "P-2"]
    assert rig.aircraft.tools() == ["flight.fly_to", "flight.hold", "flight.fly_to", "flight.hold"]


@pytest.mark.parametrize("command", ["pause", "abort", "rtl", "land"])
def test_a_pause_or_a_stop_command_interrupts_the_leg_with_a_hold(command: str) -> None:
    rig = Rig()
    with rig.flying() as box:
        getattr(rig.control, command)()
    [outcome] = box
    assert isinstance(outcome, Interrupted) and outcome.trigger is None
    expected = "paused by the operator" if command == "pause" else f"the operator asked to {command}"
    assert outcome.reason == expected
    assert rig.aircraft.tools() == ["flight.fly_to", "flight.hold"] and rig.reasoner.calls == []
    assert ("flight.fly_to", "interrupted") in rig.tool_statuses()


@pytest.mark.parametrize("command", ["abort", "rtl", "land", "pause"])
def test_a_leg_the_operator_stopped_before_it_began_is_never_sent_and_the_aircraft_holds(command: str) -> None:
    rig = Rig()
    getattr(rig.control, command)()
    with step_call("leg", state={}):
        outcome = rig.dispatch("flight.fly_to", dict(LEG), None)
    assert isinstance(outcome, Interrupted) and rig.aircraft.tools() == ["flight.hold"]
    assert ("flight.fly_to", "interrupted") in rig.tool_statuses()


@pytest.mark.parametrize("when", ["as the leg is sent", "during the leg"])
def test_between_a_stop_and_its_hold_the_world_crawls_and_afterwards_it_does_not(when: str) -> None:
    """At full speed the world must not fly on while the dispatcher gets round to the hold: from the stop (or from
    the leg's start, for a stop that came as it was being sent) until the hold is sent, the simulation runs at the
    crawl; once the leg has ended, it does not stay slowed (a stuck crawl would make every later leg take four
    times real time)."""
    rig = Rig()
    speeds: dict[str, float | None] = {}

    def record(name: str, _: dict[str, Any]) -> None:  # the pace at the moment each command reaches the vehicle
        speeds.setdefault(name, rig.pace.speed())

    rig.aircraft.on_command = record
    with rig.pace.waiting("vehicle"):  # as a run waiting on its vehicle: full speed unless slowed
        if when == "as the leg is sent":
            looked = rig.dispatch.stopping

            def stop_after_the_look() -> str | None:  # the abort lands between the dispatcher's look and the leg
                seen = looked()
                if not rig.control.stop_requested():
                    rig.control.abort()
                return seen

            rig.dispatch.stopping = stop_after_the_look  # type: ignore[method-assign]
            with step_call("leg", state={}):
                outcome = rig.dispatch("flight.fly_to", dict(LEG), None)
            assert speeds["flight.fly_to"] == URGENT_SPEED
        else:
            with rig.flying() as box:
                assert rig.pace.speed() is None
                rig.control.abort()
            (outcome,) = box
        assert isinstance(outcome, Interrupted)
        assert speeds["flight.hold"] == URGENT_SPEED
        assert rig.pace.speed() is None  # full speed again


def test_the_steps_of_a_triggers_sub_plan_are_not_watched_by_the_triggers() -> None:
    """Only the control port is (``test_dispatch_control``): a trigger's rule never turns back its own sub-plan."""
    rig = Rig("critical")
    rig.found.append((FALLEN, {"id": "P-1"}))
    with rig.flying(state={"preempted_by": "fallen"}) as box:
        assert not eventually(lambda: "flight.hold" in rig.aircraft.tools(), timeout_s=0.2)
        rig.aircraft.arrive()
    [outcome] = box
    assert isinstance(outcome, ToolResult) and outcome.status == "ok"
    assert rig.aircraft.tools() == ["flight.fly_to"] and rig.watched == [] and rig.reasoner.calls == []


@pytest.mark.parametrize("tool", ["flight.orbit", "flight.hover", "flight.fly_to"])
def test_only_long_flight_actions_are_watched(tool: str) -> None:
    rig = Rig()
    with step_call("s", state={"x": 1}):
        rig.dispatch("flight.takeoff", {}, None)
        rig.dispatch("alerts.notify", {}, None)
    assert rig.watched == []
    with rig.flying(state={"x": 1}, tool=tool):
        wait_for(lambda: len(rig.watched) > 0, what="the watch")
        rig.aircraft.arrive()
    assert rig.watched[0] == {"x": 1}  # evaluated on the state the step started from


def test_while_the_gate_thinks_the_aircraft_holds_over_the_object() -> None:
    rig_box: list[Rig] = []
    over = {"target_id": "P-1", "alt_m": 30.0}
    sent_while_thinking: list[bool] = []

    def thinking(focus: str | None) -> None:
        aircraft = rig_box[0].aircraft
        sent_while_thinking.append(eventually(lambda: over in aircraft.sent("flight.fly_to"), timeout_s=5.0))

    rig = Rig(reasoner=FakeReasoner("critical", during=thinking), hold_over=lambda event: dict(over))
    rig_box.append(rig)
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1"}))
    assert isinstance(box[0], Interrupted) and sent_while_thinking == [True]
    assert rig.aircraft.tools()[:3] == ["flight.fly_to", "flight.hold", "flight.fly_to"]
    assert rig.aircraft.sent("flight.fly_to") == [LEG, over]


def test_no_hold_over_place_sends_nothing_more() -> None:
    rig = Rig("critical", hold_over=lambda event: None)
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1"}))
    assert isinstance(box[0], Interrupted) and rig.aircraft.tools() == ["flight.fly_to", "flight.hold"]


def test_a_declined_event_leaves_the_aircraft_flying_the_leg_not_holding_over_the_object() -> None:
    over = {"target_id": "P-1", "alt_m": 30.0}
    rig = Rig("low", hold_over=lambda event: dict(over))

    def late_hold_over(tool: str, args: dict[str, Any]) -> None:
        if args == over:  # the hold-over's thread loses the race to the leg sent again
            eventually(lambda: rig.aircraft.sent("flight.fly_to").count(LEG) == 2, timeout_s=2.0)

    rig.aircraft.on_command = late_hold_over
    with rig.flying() as box:
        rig.found.append((FALLEN, {"id": "P-1"}))
        wait_for(lambda: rig.aircraft.sent("flight.fly_to").count(LEG) == 2, what="the leg sent again")
        eventually(lambda: over in rig.aircraft.sent("flight.fly_to"), timeout_s=3.0)
        rig.aircraft.arrive()  # what the aircraft was last told to do arrives
    [outcome] = box
    assert isinstance(outcome, ToolResult) and outcome.output["reached"] is True
    assert rig.aircraft.commands[-1] == ("flight.fly_to", LEG)


def test_a_leg_interrupted_by_a_pause_is_flown_again_by_an_executor_that_replays_by_key() -> None:
    rig = Rig()
    keyed = KeyedExecutor(rig.executor, replay=True)
    rig.dispatch.executor = keyed  # type: ignore[assignment]
    rig.dispatch._keyed = True
    with rig.flying() as box:
        rig.control.pause()
    assert isinstance(box[0], Interrupted)
    rig.control.resume()
    rig.aircraft.instant = True
    rerun = {"log": [{"step": "leg", "status": "interrupted"}]}  # what the runtime logged of the interruption
    with step_call("leg", state=rerun):  # the scheduler runs the blocked step again, from the start
        again = rig.dispatch("flight.fly_to", dict(LEG), None)
    assert isinstance(again, ToolResult) and again.output["reached"] is True
    assert rig.aircraft.sent("flight.fly_to") == [LEG, LEG]
