"""A compiled mission whose flight action is Interrupted: the step runs again after the trigger's sub-plan, a
repeat's pass starts again uncounted, the trigger fires from its latch though its rule no longer holds, the latch
is cleared once fired; and ``trigger_events`` (once, a running sub-plan, the last event)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pytest

from agentic_core.mission import Environment, compile_mission, initial_state
from agentic_core.mission.compile import MissionRuntime
from agentic_core.mission.steps import Interrupted, current_call, keep_approval, prepare
from agentic_core.mission.triggers import identity, may_fire, object_id, trigger_events

from .missions import PATROL, TWO_TRIGGERS, WATCHED, mission, trigger

pytestmark = pytest.mark.timeout(60)

P1 = {"id": "P-1", "class": "person", "stationary_s": 9.0}


@dataclass
class Result:
    status: str = "ok"
    output: Any = None
    error: str | None = None


class Scripted:
    """A dispatcher: records (tool, args, StepCall key); ``interrupt(n)`` makes the n-th fly_to end Interrupted."""

    def __init__(self, interrupt: Callable[[int, dict[str, Any]], Interrupted | None] = lambda n, a: None) -> None:
        self.interrupt = interrupt
        self.calls: list[tuple[str, dict[str, Any], str | None]] = []
        self._lock = threading.Lock()

    def __call__(self, tool: str, args: dict[str, Any], timeout_s: float | None) -> Result | Interrupted:
        call = current_call()
        with self._lock:
            self.calls.append((tool, args, call.key() if call else None))
            flown = sum(1 for t, _, _ in self.calls if t == "flight.fly_to")
        if tool == "flight.fly_to":
            stopped = self.interrupt(flown, args)
            if stopped is not None:
                return stopped
        return Result(output={"tool": tool})

    def tools(self) -> list[str]:
        return [tool for tool, _, _ in self.calls]


class CountingGate:
    def __init__(self, act: bool = True) -> None:
        self.act = act
        self.asked: list[tuple[str, Any]] = []

    def __call__(self, trigger: Any, event: Any) -> bool:
        self.asked.append((trigger.id, event))
        return self.act


def fly(text: str, dispatch: Scripted, world: dict[str, Any] | None = None, gate: Any = None) -> dict[str, Any]:
    plan = mission(text)
    seen = world if world is not None else {"objects": [], "relations": []}
    env = Environment(dispatch, world=lambda: seen, gate=gate)
    out: dict[str, Any] = compile_mission(plan, env).invoke(initial_state(plan), {"recursion_limit": 500})
    return out


def by_trigger(n: int, event: Any = P1, at: int = 1) -> Interrupted | None:
    return Interrupted("fallen acts on P-1", trigger="fallen", event=event) if n == at else None


def test_an_interrupted_leg_runs_again_after_the_sub_plan_and_the_trigger_fires_from_its_latch() -> None:
    dispatch = Scripted(lambda n, args: by_trigger(n))
    gate = CountingGate(act=False)  # the gate would refuse: the latch is the reasoner's earlier yes
    out = fly(WATCHED, dispatch, gate=gate)  # the person is not in the world (any more): the rule is false
    assert dispatch.tools() == ["flight.takeoff", "flight.fly_to", "alerts.notify", "flight.fly_to", "flight.rtl"]
    assert out["fired"] == ["fallen"] and out["events"]["fallen"] == P1
    assert out["status"]["leg"] == "ok" and out["status"]["warn"] == "ok" and out["status"]["home"] == "ok"
    assert out.get("latched", {}) == {} and gate.asked == []  # cleared once fired; the gate not asked again
    interrupted = [e for e in out["log"] if e.get("status") == "interrupted"]
    assert interrupted == [{"step": "leg", "status": "interrupted", "error": "fallen acts on P-1", "trigger": "fallen"}]
    notify = [args for tool, args, _ in dispatch.calls if tool == "alerts.notify"]
    assert notify[0]["subject"] == "P-1"  # the sub-plan reads the latched event
    legs = [key for tool, _, key in dispatch.calls if tool == "flight.fly_to"]
    assert legs == ["leg:1.1", "leg~1:1.1"]  # the step runs again from its start, as a new call (no replay)


def test_an_interruption_without_a_trigger_blocks_the_step_and_it_runs_again() -> None:
    dispatch = Scripted(lambda n, args: Interrupted("paused by the operator") if n == 1 else None)
    out = fly(WATCHED, dispatch)
    assert dispatch.tools().count("flight.fly_to") == 2 and out["status"]["leg"] == "ok"
    assert out.get("fired", []) == [] and out.get("latched", {}) == {}


class Approver:
    """A headless operator: approves every request, with ``edits`` of the arguments; records what it was asked."""

    def __init__(self, edits: dict[str, Any] | None = None) -> None:
        self.edits = edits
        self.asked: list[dict[str, Any]] = []

    def __call__(self, request: dict[str, Any]) -> Any:
        self.asked.append(request)
        return {"approve": True, "args": self.edits} if self.edits else True


def fly_approved(text: str, dispatch: Scripted, approver: Approver) -> dict[str, Any]:
    plan = mission(text)
    env = Environment(dispatch, world=lambda: {"objects": [], "relations": []}, approve=approver)
    out: dict[str, Any] = compile_mission(plan, env).invoke(initial_state(plan), {"recursion_limit": 500})
    return out


APPROVED_LEG = WATCHED.replace("{id: leg, action: fly_to,", "{id: leg, action: fly_to, approval: true,")
APPROVED_PATROL = PATROL.replace("    action: repeat\n", "    action: repeat\n    approval: true\n")


def test_a_pause_keeps_the_operators_approval_and_the_step_flies_again_with_the_arguments_approved() -> None:
    dispatch = Scripted(lambda n, args: Interrupted("paused by the operator") if n == 1 else None)
    approver = Approver(edits={"north_m": 80})
    out = fly_approved(APPROVED_LEG, dispatch, approver)
    assert [r["step"] for r in approver.asked] == ["leg"]  # asked once, not again after the pause
    legs = [args for tool, args, _ in dispatch.calls if tool == "flight.fly_to"]
    assert [leg["north_m"] for leg in legs] == [80, 80]  # the operator's edit, both times
    assert out["status"]["leg"] == "ok" and out["approved"] == {"leg": {"run": None, "args": legs[0]}}
    (entry,) = [e for e in out["log"] if e.get("status") == "interrupted"]
    assert entry["approval"] == "kept" and entry["trigger"] is None


@pytest.mark.parametrize(
    ("kept", "asked"),
    [
        ({"run": "flight-1", "args": {"north_m": 80}}, False),  # this run's: flies with it
        ({"run": "flight-0", "args": {"north_m": 80}}, True),  # the run it was forked from: asked again
        ({"north_m": 80}, True),  # kept before approvals named their run: asked again
        ({"run": "flight-1", "args": "north_m=80"}, True),  # not arguments: asked again
    ],
)
def test_a_kept_approval_holds_in_the_run_that_gave_it_only(kept: dict[str, Any], asked: bool) -> None:
    plan = mission(APPROVED_LEG)
    (leg,) = [s for s in plan.steps if s.id == "leg"]
    approver = Approver()
    env = Environment(Scripted(lambda n, args: None), approve=approver, run_id="flight-1")
    args = prepare(leg, {"approved": {"leg": kept}, "outputs": {}}, env)
    assert bool(approver.asked) is asked
    assert asked or args == {"north_m": 80}
    assert keep_approval(args, env) == {"run": "flight-1", "args": args}


def test_a_trigger_that_takes_over_an_approved_step_has_it_asked_again() -> None:
    dispatch = Scripted(lambda n, args: by_trigger(n))
    approver = Approver()
    out = fly_approved(APPROVED_LEG, dispatch, approver)
    assert [r["step"] for r in approver.asked] == ["leg", "leg"]  # the situation changed: asked again
    assert out.get("approved", {}) == {} and out["status"]["leg"] == "ok"
    (entry,) = [e for e in out["log"] if e.get("status") == "interrupted"]
    assert "approval" not in entry


def test_an_approval_kept_over_a_pause_is_asked_again_once_a_trigger_takes_the_step_over() -> None:
    def stop(n: int, args: dict[str, Any]) -> Interrupted | None:
        return Interrupted("paused by the operator") if n == 1 else by_trigger(n, at=2)

    dispatch = Scripted(stop)
    approver = Approver()
    out = fly_approved(APPROVED_LEG, dispatch, approver)
    assert [r["step"] for r in approver.asked] == ["leg", "leg"]  # kept over the pause, asked after the trigger
    assert dispatch.tools().count("flight.fly_to") == 3 and out["status"]["leg"] == "ok"
    assert out["approved"] == {"leg": None}


def test_a_paused_approved_repeat_starts_its_pass_again_without_asking_again() -> None:
    dispatch = Scripted(lambda n, args: Interrupted("paused by the operator") if n == 2 else None)
    approver = Approver()
    out = fly_approved(APPROVED_PATROL, dispatch, approver)
    assert [r["step"] for r in approver.asked] == ["patrol"]
    assert out["outputs"]["patrol"]["iterations"] == 2 and out["status"]["patrol"] == "ok"
    assert dispatch.tools().count("flight.fly_to") == 6  # gate_a, gate_b (paused), then two whole passes


def test_an_interrupted_repeat_starts_its_pass_again_and_does_not_count_it() -> None:
    dispatch = Scripted(lambda n, args: by_trigger(n, at=2))  # gate_b of the first pass
    out = fly(PATROL, dispatch)
    legs = [key for tool, _, key in dispatch.calls if tool == "flight.fly_to"]
    passes = [key.split("#")[1].split(":")[0] for key in legs if key]
    assert passes == ["1", "1", "1", "1", "2", "2"]  # the first pass flown again from its first gate
    assert [key.split("/")[1].split("#")[0] for key in legs if key] == ["gate_a", "gate_b"] * 3
    assert out["outputs"]["patrol"]["iterations"] == 2 and out["status"]["patrol"] == "ok"
    assert out["fired"] == ["fallen"] and out["status"]["warn"] == "ok"
    assert dispatch.tools().index("alerts.notify") == 3  # the sub-plan ran before the pass started again


def test_a_latched_trigger_that_may_no_longer_fire_does_not() -> None:
    plan = mission(TWO_TRIGGERS)
    rt = MissionRuntime(plan, Environment(Scripted(), gate=CountingGate()))
    fallen = trigger("fallen")
    assert rt.fires(fallen, {"latched": {"fallen": P1}}) == P1
    assert rt.fires(fallen, {"latched": {"fallen": P1}, "fired": ["fallen"]}) is None  # once: spent


def test_a_latch_fires_before_any_other_event_the_rule_finds() -> None:
    world = {"objects": [{"id": "P-9", "class": "person"}], "relations": []}
    gate = CountingGate()
    rt = MissionRuntime(mission(TWO_TRIGGERS), Environment(Scripted(), world=lambda: world, gate=gate))
    assert rt.fires(trigger("fallen"), {"latched": {"fallen": P1}}) == P1 and gate.asked == []
    assert rt.fires(trigger("fallen"), {}) == world["objects"][0] and len(gate.asked) == 1


# ---- trigger_events


def events_of(trigger_id: str, state: dict[str, Any], world: dict[str, Any] | Callable[[], Any]) -> list[Any]:
    provider = world if callable(world) else (lambda: world)
    return trigger_events(trigger(trigger_id), state, Environment(Scripted(), world=provider))


TWO = {"objects": [{"id": "P-1", "class": "person"}, {"id": "P-2", "class": "person"}], "relations": []}


def test_trigger_events_finds_every_event_before_the_first_firing() -> None:
    assert [e["id"] for e in events_of("fallen", {}, TWO)] == ["P-1", "P-2"]
    assert events_of("fallen", {}, {"objects": [], "relations": []}) == []


def test_trigger_events_honours_once() -> None:
    assert events_of("fallen", {"fired": ["fallen"], "events": {"fallen": TWO["objects"][0]}}, TWO) == []
    assert not may_fire(trigger("fallen"), {"fired": ["fallen"]})


def test_trigger_events_waits_while_the_last_sub_plan_runs() -> None:
    state = {
        "fired": ["again"],
        "events": {"again": TWO["objects"][0]},
        "spliced": {"note": {"origin": "trigger:again", "deps": [], "step": {}}},
        "status": {"note": "scheduled"},
    }
    assert events_of("again", state, TWO) == []
    done = {**state, "status": {"note": "ok"}}
    assert [e["id"] for e in events_of("again", done, TWO)] == ["P-2"]  # not the last event again


def test_the_last_event_is_known_by_its_id_not_its_changing_fields() -> None:
    moved = {"objects": [{"id": "P-1", "class": "person", "stationary_s": 99.0}], "relations": []}
    state = {"fired": ["again"], "events": {"again": {"id": "P-1", "class": "person", "stationary_s": 1.0}}}
    assert events_of("again", state, moved) == []
    assert identity({"id": "P-1", "x": 1}) == identity({"id": "P-1", "x": 2}) == "P-1"
    assert object_id({"no": "id"}) is None and object_id({"id": 7}) == "7" and identity(3) == 3


@pytest.mark.parametrize("world", [{"relations": []}, {"objects": "not a list", "relations": []}, None])
def test_a_rule_that_cannot_be_evaluated_yet_finds_nothing(world: Any) -> None:
    assert events_of("fallen", {}, lambda: world) == []
    assert [e["id"] for e in events_of("fallen", {}, TWO)] == ["P-1", "P-2"]  # the same rule, once it can look
