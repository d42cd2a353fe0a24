"""Dispatcher: idempotency keys (``run_id:`` + the StepCall key, given only to an executor that takes one;
distinct per pass, attempt and call; the same when a step is run again, as after a resume), the wait each tool
runs under, ``prepare`` hooks, and the ``tool`` event of every call."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.agent import ControlPort, Dispatcher, Gate, Pace
from agentic_core.graph import CompiledStateGraph, InMemorySaver
from agentic_core.mission import Environment, compile_mission, initial_state
from agentic_core.mission.steps import step_call

from .fakes import Aircraft, Events, FakeReasoner, FakeVehicle, FakeWorld, executor_for
from .missions import PATROL, SURVEY, mission
from .stand_ins import Crash, KeyedExecutor, PlainExecutor

pytestmark = pytest.mark.timeout(60)

RETRIED = """
plan_id: retried
goal: check twice before going
steps:
  - {id: check, action: call_tool, tool: svc.check, max_retries: 2, on_fail: skip}
  - {id: up, action: takeoff, depends_on: [check], args: {altitude_m: 30}}
"""


def dispatcher(executor: Any, run_id: str = "run-1", pace: Pace | None = None, **options: Any) -> Dispatcher:
    events = options.pop("events", Events())
    pace = pace or Pace(None)
    gate = Gate(FakeReasoner("low"), FakeWorld(), FakeVehicle(), events.publish, pace)
    return Dispatcher(
        executor, run_id=run_id, gate=gate, control=ControlPort(), pace=pace, publish=events.publish, **options
    )


def fly(text: str, dispatch: Dispatcher, checkpointer: InMemorySaver | None = None) -> CompiledStateGraph:
    return compile_mission(mission(text), Environment(dispatch), checkpointer=checkpointer)


def run(text: str, dispatch: Dispatcher) -> dict[str, Any]:
    out: dict[str, Any] = fly(text, dispatch).invoke(initial_state(mission(text)), {"recursion_limit": 500})
    return out


def keyed(replay: bool = False, extra: dict[str, Any] | None = None) -> KeyedExecutor:
    return KeyedExecutor(executor_for(Aircraft(instant=True), extra), replay=replay)


def test_the_key_is_the_run_id_and_the_step_call_key_and_distinct_for_every_pass() -> None:
    executor = keyed()
    out = run(PATROL, dispatcher(executor, run_id="run-7"))
    assert out["status"]["patrol"] == "ok" and out["outputs"]["patrol"]["iterations"] == 2
    keys = executor.keys()
    assert len(keys) == len(set(keys)) == 6  # take-off, 2 passes x 2 gates, home
    assert all(key is not None and key.startswith("run-7:") for key in keys)
    gates = [k for k in executor.keys("flight.fly_to") if k is not None]
    for gate in ("gate_a", "gate_b"):
        mine = [k for k in gates if f"patrol/{gate}#" in k]
        assert [k.split("#")[1].split(":")[0] for k in mine] == ["1", "2"]  # the pass is in the key


def test_keys_differ_per_attempt() -> None:
    tries = [0]

    def check(args: dict[str, Any]) -> dict[str, Any]:
        tries[0] += 1
        if tries[0] < 3:
            raise RuntimeError("not yet")
        return {"ok": True}

    executor = keyed(extra={"svc.check": check})
    out = run(RETRIED, dispatcher(executor))
    assert out["status"]["check"] == "ok" and out["attempts"]["check"] == 3
    keys = executor.keys("svc.check")
    assert len(keys) == len(set(keys)) == 3
    assert [k.rsplit(":", 1)[1].split(".")[0] for k in keys if k] == ["1", "2", "3"]


def test_keys_differ_for_successive_calls_of_one_attempt_the_legs_of_a_survey() -> None:
    executor = keyed()
    out = run(SURVEY, dispatcher(executor))
    legs = executor.keys("flight.fly_to")
    assert out["outputs"]["sweep"]["legs"] == len(legs) >= 3
    assert len(set(legs)) == len(legs)
    assert [k.rsplit(".", 1)[1] for k in legs if k] == [str(n) for n in range(1, len(legs) + 1)]


def test_the_same_mission_run_again_under_the_same_run_id_makes_the_same_keys() -> None:
    first, second, other = keyed(), keyed(), keyed()
    run(PATROL, dispatcher(first, run_id="run-1"))
    run(PATROL, dispatcher(second, run_id="run-1"))
    run(PATROL, dispatcher(other, run_id="run-2"))
    assert first.keys() == second.keys()
    assert not set(first.keys()) & set(other.keys())


def test_a_step_run_again_after_a_crash_and_resume_gets_the_same_key() -> None:
    executor = keyed()
    crashed: list[str | None] = []

    def crash_once(tool: str, args: dict[str, Any]) -> None:
        if tool == "flight.rtl" and not crashed:  # the last step: everything before it is checkpointed
            crashed.append(tool)
            raise Crash

    executor.before = crash_once
    saver = InMemorySaver()
    graph = fly(PATROL, dispatcher(executor, run_id="run-3"), saver)
    config = {"configurable": {"thread_id": "t"}, "recursion_limit": 500}
    with pytest.raises(Crash):
        graph.invoke(initial_state(mission(PATROL)), config)
    done = executor.keys()  # the take-off, the legs, and the rtl the process died in
    resumed = fly(PATROL, dispatcher(executor, run_id="run-3"), saver)
    out = resumed.invoke(None, config)
    assert out["status"]["home"] == "ok"
    fresh = keyed()
    run(PATROL, dispatcher(fresh, run_id="run-3"))
    assert len(done) == 6 and executor.keys() == [*done, done[-1]]  # only the rtl again, under the key it had
    assert executor.keys()[:-1] == fresh.keys()  # and the same keys as a run that never crashed


def test_an_executor_without_idempotency_keys_is_not_given_one_but_the_event_names_it() -> None:
    events = Events()
    executor = PlainExecutor(executor_for(Aircraft(instant=True)))
    out = run(PATROL, dispatcher(executor, run_id="run-9", events=events))
    assert out["status"]["home"] == "ok" and executor.keys() == [None] * 6
    keys = [e["key"] for e in events.of("tool")]
    assert len(keys) == 6 and all(k.startswith("run-9:") for k in keys)


def test_the_real_executor_is_called_without_a_key() -> None:
    aircraft = Aircraft(instant=True)
    out = run(PATROL, dispatcher(executor_for(aircraft)))
    assert out["status"]["home"] == "ok" and aircraft.tools().count("flight.fly_to") == 4


def test_outside_a_mission_step_there_is_no_key() -> None:
    executor = keyed()
    result = dispatcher(executor)("flight.takeoff", {"altitude_m": 10}, None)
    assert getattr(result, "status", None) == "ok" and executor.keys() == [None]


@pytest.mark.parametrize(
    ("tool", "speed"),
    [("flight.takeoff", None), ("flight.fly_to", None), ("alerts.notify", 1.0), ("perception.analyze_scene", 1.0)],
)
def test_flight_tools_run_under_a_vehicle_wait_and_other_tools_under_a_tool_wait(
    tool: str, speed: float | None
) -> None:
    pace = Pace(None)
    executor = KeyedExecutor(executor_for(Aircraft(instant=True)), pace)
    dispatch = dispatcher(executor, pace=pace)
    with step_call("s", state={}):
        dispatch(tool, {}, None)
    assert [s for _, _, _, s in executor.calls] == [speed] and pace.speed() == 1.0


def test_prepare_hooks_rewrite_the_arguments_the_tool_and_the_trace_see() -> None:
    events = Events()
    executor = keyed()
    seen: list[dict[str, Any]] = []

    def attach(args: dict[str, Any]) -> dict[str, Any]:
        seen.append(args)
        return {**args, "attachments": ["alerts/frame.jpg"]}

    dispatch = dispatcher(executor, prepare={"alerts.notify": attach}, events=events)
    with step_call("warn", state={}):
        dispatch("alerts.notify", {"subject": "P-1"}, None)
        dispatch("flight.hold", {"why": "untouched"}, None)
    assert seen == [{"subject": "P-1"}]
    assert [args for _, args, _, _ in executor.calls] == [
        {"subject": "P-1", "attachments": ["alerts/frame.jpg"]},
        {"why": "untouched"},
    ]
    assert events.of("tool")[0]["args"] == {"subject": "P-1", "attachments": ["alerts/frame.jpg"]}


def test_every_call_is_published_as_a_tool_event_with_its_outcome() -> None:
    events = Events()
    dispatch = dispatcher(keyed(extra={"svc.broken": lambda args: 1 / 0}), events=events)
    with step_call("s", state={}):
        dispatch("svc.broken", {}, 5.0)
        dispatch("flight.hold", {}, None)
    broken, held = events.of("tool")
    assert broken["name"] == "svc.broken" and broken["status"] == "error" and "ZeroDivisionError" in broken["error"]
    assert broken["summary"].startswith("svc.broken error: ") and broken["replayed"] is False
    assert held["status"] == "ok" and held["summary"] == "flight.hold ok"
    assert broken["key"] == held["key"] == "run-1:s:1.0"  # numbered by the step runner, not by the dispatcher


def test_a_replayed_result_is_marked_in_the_event() -> None:
    events = Events()
    executor = keyed(replay=True)
    dispatch = dispatcher(executor, events=events)
    for _ in range(2):
        with step_call("s", state={}):
            dispatch("flight.takeoff", {}, None)
    assert len(executor.calls) == 1 and executor.replayed  # the stand-in replayed the second
    assert [e["replayed"] for e in events.of("tool")] == [False, False]  # a ToolResult has no replayed flag
