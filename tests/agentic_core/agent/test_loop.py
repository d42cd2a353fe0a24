"""AgentLoop over a compiled mission and fakes: a pause between supersteps holds it until resume, abort stops
it, an approval (``interrupt``) is asked on the control port and answered from another thread, the wall-clock
limit stops it, and what the nodes changed is published."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

import pytest

from agentic_core.agent import AgentLoop, ControlPort, LoopResult, Pace, policy_approval
from agentic_core.agent.envelope import Envelope
from agentic_core.contracts.policy_graph import Limits
from agentic_core.graph import InMemorySaver
from agentic_core.mission import Environment, compile_mission, initial_state

from .fakes import Aircraft, Events, eventually, executor_for, wait_for
from .missions import WATCHED, mission
from .stand_ins import PlainExecutor
from .test_dispatch_keys import dispatcher
from .test_mission_interrupts import Scripted, by_trigger

pytestmark = pytest.mark.timeout(60)

PLAIN = """
plan_id: plain
goal: up, across, home
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - {id: leg, action: fly_to, depends_on: [up], args: {north_m: 100, east_m: 0, alt_m: 30}}
  - {id: home, action: rtl, depends_on: [leg]}
"""

APPROVAL = """
plan_id: approval
goal: land where the operator says
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - {id: down, action: land, depends_on: [up], approval: true, on_fail: rtl}
"""


class Looping:
    """An AgentLoop over ``text`` with a Scripted dispatcher; ``on_tool`` runs at each dispatch (to pause...)."""

    def __init__(self, text: str, *, ask: bool = False, **options: Any) -> None:
        self.events = Events()
        self.control = ControlPort()
        self.pace = Pace(None)
        self.dispatch = options.pop("dispatch", None) or Scripted()
        self.plan = mission(text)
        graph = compile_mission(self.plan, Environment(self.dispatch), checkpointer=InMemorySaver())
        self.loop = AgentLoop(
            graph, {"configurable": {"thread_id": "t"}, "recursion_limit": 500}, control=self.control,
            publish=self.events.publish, pace=self.pace, ask=ask, **options,
        )  # fmt: skip
        self.result: list[LoopResult] = []
        self.thread: threading.Thread | None = None

    def start(self) -> None:
        self.thread = threading.Thread(target=lambda: self.result.append(self.run()), daemon=True)
        self.thread.start()

    def run(self) -> LoopResult:
        return self.loop.run(initial_state(self.plan))

    def finish(self) -> LoopResult:
        assert self.thread is not None
        self.thread.join(20)
        assert not self.thread.is_alive(), "the loop did not end"
        return self.result[0]

    def logged(self) -> list[str | None]:
        return self.events.summaries("log")


def at_tool(looping: Looping, tool: str, command: Callable[[], None]) -> None:
    """Give ``command`` on the control port as ``tool`` is dispatched (the graph recompiled over that hook)."""
    inner = looping.dispatch

    def dispatch(name: str, args: dict[str, Any], timeout_s: float | None) -> Any:
        if name == tool:
            command()
        return inner(name, args, timeout_s)

    looping.loop.graph = compile_mission(looping.plan, Environment(dispatch), checkpointer=InMemorySaver())


def pause_at(looping: Looping, tool: str) -> None:
    at_tool(looping, tool, lambda: looping.control.pause(by="test"))


def test_a_pause_between_supersteps_holds_the_loop_until_resume() -> None:
    looping = Looping(PLAIN)
    pause_at(looping, "flight.takeoff")
    looping.start()
    wait_for(lambda: "paused: holding until resumed" in looping.logged(), what="the loop to hold")
    assert not eventually(lambda: "flight.fly_to" in looping.dispatch.tools(), timeout_s=0.3)
    assert looping.pace.speed() == 1.0  # the operator is awaited: real time
    threading.Thread(target=lambda: looping.control.resume(by="console")).start()
    result = looping.finish()
    assert result.stopped is None and not result.over_time
    assert looping.dispatch.tools() == ["flight.takeoff", "flight.fly_to", "flight.rtl"]
    assert all(result.state["status"][s] == "ok" for s in ("up", "leg", "home"))
    assert looping.logged().index("paused: holding until resumed") < looping.logged().index("resumed")


@pytest.mark.parametrize("stop", ["abort", "rtl", "land"])
def test_a_stop_command_ends_the_loop_and_no_further_step_starts(stop: str) -> None:
    looping = Looping(PLAIN)
    pause_at(looping, "flight.takeoff")
    looping.start()
    wait_for(lambda: "paused: holding until resumed" in looping.logged(), what="the loop to hold")
    threading.Thread(target=lambda: getattr(looping.control, stop)()).start()
    result = looping.finish()
    assert result.stopped == stop and not result.over_time
    assert looping.dispatch.tools() == ["flight.takeoff"] and result.state["status"]["up"] == "ok"
    assert "resumed" not in looping.logged()


def test_abort_without_a_pause_stops_after_the_superstep() -> None:
    looping = Looping(PLAIN)
    at_tool(looping, "flight.takeoff", lambda: looping.control.abort("test"))
    result = looping.run()
    assert result.stopped == "abort" and looping.dispatch.tools() == ["flight.takeoff"]


@pytest.mark.parametrize("approve", [True, False])
def test_an_approval_is_asked_on_the_control_port_and_answered_from_another_thread(approve: bool) -> None:
    looping = Looping(APPROVAL, ask=True, approval_timeout_s=30)
    looping.start()
    wait_for(lambda: len(looping.control.pending()) == 1, what="the question")
    [question] = looping.control.pending()
    assert question.request["step"] == "down" and question.request["action"] == "land"
    assert looping.pace.speed() == 1.0  # the operator is awaited
    answer = looping.control.approve if approve else looping.control.decline
    threading.Thread(target=lambda: answer(question.id, "checked", by="console")).start()
    result = looping.finish()
    assert ("flight.land" in looping.dispatch.tools()) is approve
    assert result.state["status"]["down"] == ("ok" if approve else "failed")
    asked, answered = looping.events.of("approval")
    assert asked["status"] == "asked" and answered["answer"] is approve and answered["said"] == "checked"
    assert answered["via"] == "operator"


def test_an_unanswered_approval_times_out_to_a_decline() -> None:
    looping = Looping(APPROVAL, ask=True, approval_timeout_s=0.2)
    result = looping.run()
    assert "flight.land" not in looping.dispatch.tools() and result.state["status"]["down"] == "failed"
    assert looping.events.of("approval")[-1]["answer"] is False


def test_a_stop_while_an_approval_is_asked_ends_the_loop_without_landing() -> None:
    looping = Looping(APPROVAL, ask=True, approval_timeout_s=30)
    looping.start()
    wait_for(lambda: len(looping.control.pending()) == 1, what="the question")
    threading.Thread(target=lambda: looping.control.rtl(by="console")).start()
    result = looping.finish()
    assert result.stopped == "rtl" and "flight.land" not in looping.dispatch.tools()


def test_max_wall_s_stops_the_loop_over_time() -> None:
    looping = Looping(PLAIN, max_wall_s=0.0)
    result = looping.run()
    assert result.over_time and result.stopped is None
    assert looping.dispatch.tools() == ["flight.takeoff"]


def test_what_the_nodes_changed_is_published() -> None:
    updates: list[int] = []
    looping = Looping(WATCHED, dispatch=Scripted(lambda n, args: by_trigger(n)))
    looping.loop.after_update = lambda: updates.append(1)
    result = looping.run()
    steps = [(e["step"], e["status"]) for e in looping.events.of("step")]
    assert ("leg", "blocked") in steps and ("leg", "ok") in steps and ("warn", "ok") in steps
    mission_log = [e["status"] for e in looping.events.of("mission")]
    assert "interrupted" in mission_log and "fired" in mission_log
    assert result.state["status"]["home"] == "ok" and len(updates) >= 4


def test_the_headless_policy_answers_and_publishes_like_an_operator() -> None:
    events = Events()
    approve = policy_approval(True, events.publish)
    assert approve({"step": "down"}) is True and policy_approval(False, events.publish)({"step": "x"}) is False
    assert [(e["answer"], e["via"]) for e in events.of("approval")] == [(True, "policy"), (False, "policy")]


APPROVAL_AT = """
plan_id: approval-at
goal: land where the operator says
steps:
  - {id: up, action: takeoff, args: {altitude_m: 30}}
  - {id: down, action: land, depends_on: [up], approval: true, on_fail: rtl, args: {lat: 21.4135, lon: 39.8933}}
"""


def answered_with(edits: dict[str, Any], **options: Any) -> tuple[Looping, LoopResult]:
    looping = Looping(APPROVAL_AT, ask=True, approval_timeout_s=30, **options)
    looping.start()
    wait_for(lambda: len(looping.control.pending()) == 1, what="the question")
    [question] = looping.control.pending()
    threading.Thread(target=lambda: looping.control.approve(question.id, by="console", args=edits)).start()
    return looping, looping.finish()


def test_an_operator_may_approve_with_edited_arguments_and_the_step_flies_them() -> None:
    looping, result = answered_with({"lat": 21.4136})
    assert result.state["status"]["down"] == "ok"
    (landed,) = [args for tool, args, _ in looping.dispatch.calls if tool == "flight.land"]
    assert landed["lat"] == 21.4136 and landed["lon"] == 39.8933
    answered = looping.events.of("approval")[-1]
    assert answered["answer"] is True and answered["edited"] == {"lat": 21.4136}


@pytest.mark.parametrize("edits", [{"target_id": "P-01"}, {"lat": 21.4136, "alt_m": 3}], ids=["new-name", "one-new"])
def test_an_edit_naming_an_argument_the_step_does_not_have_is_refused_and_nothing_lands(
    edits: dict[str, Any],
) -> None:
    looping, result = answered_with(edits)
    assert "flight.land" not in looping.dispatch.tools()
    assert result.state["status"]["down"] == "failed"


def test_an_edit_that_takes_the_landing_outside_the_fence_is_refused_by_the_envelope_and_never_flown() -> None:
    limits = Limits.model_validate({"geofence": {"center": {"lat": 21.4133, "lon": 39.8933}, "radius_m": 200}})
    executor = PlainExecutor(executor_for(Aircraft(instant=True)))
    envelope = Envelope(limits, home=lambda: (21.4133, 39.8933), targets=lambda _: None)
    _, result = answered_with({"lat": 21.4233}, dispatch=dispatcher(executor, envelope=envelope))  # 1.1 km north
    assert result.state["status"]["down"] == "failed"
    assert "flight.land" not in [tool for tool, *_ in executor.calls]
    assert "outside the flight envelope" in str(result.state["errors"]["down"])


TIMES_OUT = """
plan_id: times_out
goal: a wait that fails, on the ground
steps:
  - {id: wait, action: wait_until, condition: "1 > 2", timeout_s: 0.2, poll_s: 0.05}
"""


def test_a_failed_step_says_why_in_its_event() -> None:
    """The reason a step failed reaches the trace and the terminal, not only ``wait failed``."""
    looping = Looping(TIMES_OUT)
    looping.run()
    (failed,) = [e for e in looping.events.of("step") if e["step"] == "wait"]
    assert failed["status"] == "failed"
    assert "'1 > 2' still false after 0.2 s" in failed["error"]
    assert failed["summary"] == f"wait failed: {failed['error']}"


NEVER = """
plan_id: never
goal: wait for what never comes
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: wait, action: wait_until, depends_on: [up], condition: "1 > 2", poll_s: 0.05}
"""


@pytest.mark.parametrize("stop", ["abort", "wall clock"])
def test_a_wait_that_never_comes_true_gives_way_to_a_stop(stop: str) -> None:
    """A ``wait_until`` calls no tool a dispatcher could interrupt: it asks the environment at each poll whether the
    run is being stopped, so an abort, or the wall-clock limit, ends it (before, the loop waited forever)."""
    looping = Looping(NEVER, max_wall_s=0.5 if stop == "wall clock" else 60.0)
    control = looping.control
    polls: list[float] = []

    def stopping() -> str | None:
        polls.append(1.0)
        return "stop" if control.stop_requested() else None

    env = Environment(looping.dispatch, stopping=stopping)
    looping.loop.graph = compile_mission(looping.plan, env, checkpointer=InMemorySaver())
    looping.start()
    if stop == "abort":
        wait_for(lambda: len(polls) >= 3, what="the wait to poll")
        threading.Thread(target=lambda: control.abort(by="test")).start()
    result = looping.finish()
    if stop == "abort":
        assert result.stopped == "abort" and not result.over_time
    else:
        assert result.over_time and result.stopped is None
    assert result.state["status"]["wait"] == "blocked"  # given way, to run again if the run goes on
    assert {"step": "wait", "status": "interrupted", "error": "stop", "trigger": None} in result.state["log"]
