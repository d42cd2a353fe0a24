"""Compiled missions against a recording dispatcher: parallelism, ordering, retries, the on_fail policies,
the reflection splice, approvals, triggers, repeat, branch, survey and wait_until."""

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

from agentic_core.graph import Command, InMemorySaver
from agentic_core.mission import Environment, Failure, compile_mission, initial_state, load_mission
from agentic_core.mission.geometry import lawnmower
from agentic_core.mission.layers import layers

MISSIONS = Path(__file__).resolve().parents[3] / "missions"


@dataclass
class Result:
    status: str
    output: Any = None
    error: str | None = None


@dataclass
class Recorder:
    """A dispatcher that records every call and answers from a script: tool -> callable(args) -> Result."""

    script: dict[str, Callable[[dict[str, Any]], Result]] = field(default_factory=dict)
    calls: list[tuple[str, dict[str, Any]]] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def __call__(self, tool: str, args: dict[str, Any], timeout_s: float | None) -> Result:
        with self.lock:
            self.calls.append((tool, args))
        answer = self.script.get(tool)
        return answer(args) if answer else Result("ok", {"tool": tool})

    def tools(self) -> list[str]:
        return [tool for tool, _ in self.calls]


def run(text: str, rec: Recorder, **kw: Any) -> dict[str, Any]:
    plan = load_mission(text, file="test.yaml")
    app = compile_mission(plan, Environment(rec, **kw.pop("env", {})), **kw)
    out: dict[str, Any] = app.invoke(initial_state(plan), {"recursion_limit": 500})
    return out


def weather(wind: float) -> Callable[[dict[str, Any]], Result]:
    return lambda args: Result("ok", {"current": {"wind_speed_mps": wind}})


def test_independent_steps_run_in_the_same_superstep_and_dependents_after() -> None:
    barrier = threading.Barrier(2, timeout=5)

    def meet(output: Any) -> Callable[[dict[str, Any]], Result]:
        def answer(args: dict[str, Any]) -> Result:
            barrier.wait()  # breaks unless the weather check and the take-off run at the same time
            return Result("ok", output)

        return answer

    rec = Recorder({"weather.get_forecast": meet({"current": {"wind_speed_mps": 7}}), "flight.takeoff": meet({})})
    out = run((MISSIONS / "inspect_perimeter.yaml").read_text(), rec)
    assert set(rec.tools()[:2]) == {"weather.get_forecast", "flight.takeoff"}
    assert rec.tools()[2:] == ["flight.fly_to", "perception.analyze_scene", "flight.rtl"]
    assert rec.calls[2][1] == {"lat": 21.4141, "lon": 39.8952, "alt_m": 40.0}  # templates filled in
    assert all(v == "ok" for v in out["status"].values())
    assert layers(load_mission(MISSIONS / "inspect_perimeter.yaml")) == [
        ["check_weather", "climb"],
        ["inspect_anomaly"],
        ["look"],
        ["go_home"],
    ]


def test_a_false_precondition_fails_the_step_and_the_default_reflector_aborts() -> None:
    rec = Recorder({"weather.get_forecast": weather(20)})
    out = run((MISSIONS / "inspect_perimeter.yaml").read_text(), rec)
    assert "flight.fly_to" not in rec.tools()
    assert out["status"]["inspect_anomaly"] == "failed"
    precondition = "check_weather.current.wind_speed_mps < params.wind_limit_mps"
    assert f"precondition {precondition!r} is false" in out["errors"]["inspect_anomaly"]
    assert out["halt"] == "abort"
    assert out["status"]["look"] in ("blocked", "cancelled")
    assert "go_home" not in out["status"] or out["status"]["go_home"] != "ok"


def flaky(failures: int, output: Any = None) -> Callable[[dict[str, Any]], Result]:
    left = [failures]

    def answer(args: dict[str, Any]) -> Result:
        if left[0] > 0:
            left[0] -= 1
            return Result("error", error="service unavailable")
        return Result("ok", output)

    return answer


def test_retries_then_success() -> None:
    rec = Recorder({"weather.get_forecast": flaky(2, {"current": {"wind_speed_mps": 5}})})
    out = run((MISSIONS / "inspect_perimeter.yaml").read_text(), rec)
    assert rec.tools().count("weather.get_forecast") == 3
    assert out["attempts"]["check_weather"] == 3 and out["status"]["check_weather"] == "ok"


def test_retries_exhausted_then_the_policy() -> None:
    rec = Recorder({"weather.get_forecast": flaky(5)})
    out = run((MISSIONS / "inspect_perimeter.yaml").read_text(), rec)
    assert rec.tools().count("weather.get_forecast") == 3
    assert "after 3 attempts" in out["errors"]["check_weather"]
    assert out["halt"] == "abort" and "flight.fly_to" not in rec.tools()


POLICY = """
plan_id: policies
goal: test on_fail
on_abort: hold
steps:
  - {id: first, action: hover, args: {duration_s: 1}}
  - {id: risky, action: call_tool, tool: svc.flaky, depends_on: [first], on_fail: POLICY}
  - {id: after, action: hover, depends_on: [risky], args: {duration_s: 2}}
"""


@pytest.mark.parametrize(
    ("policy", "halt", "after_runs", "rtl_sent"),
    [
        ("skip", None, True, False),
        ("abort", "abort", False, False),
        ("rtl", "rtl", False, True),
        ("retry", "abort", False, False),
    ],
)
def test_on_fail_policies(policy: str, halt: str | None, after_runs: bool, rtl_sent: bool) -> None:
    rec = Recorder({"svc.flaky": flaky(99)})
    out = run(POLICY.replace("POLICY", policy), rec)
    assert out.get("halt") == halt
    assert (rec.tools().count("flight.hover") == 2) is after_runs
    assert ("flight.rtl" in rec.tools()) is rtl_sent
    assert ("flight.hold" in rec.tools()) is (halt == "abort")  # the mission's on_abort: hold
    assert out["status"]["risky"] == ("skipped" if policy == "skip" else "failed")


@pytest.mark.parametrize(("on_abort", "tool"), [(None, "flight.rtl"), ("rtl", "flight.rtl"), ("land", "flight.land"),
                                               ("hold", "flight.hold")])  # fmt: skip
def test_an_aborted_mission_does_what_its_on_abort_says(on_abort: str | None, tool: str) -> None:
    """By default an aborted mission returns to launch; ``on_abort`` may say land or hold instead."""
    rec = Recorder({"svc.flaky": flaky(99)})
    text = POLICY.replace("POLICY", "abort").replace("on_abort: hold\n", f"on_abort: {on_abort}\n" if on_abort else "")
    out = run(text, rec)
    assert out["halt"] == "abort" and rec.tools()[-1] == tool
    assert [t for t in rec.tools() if t in ("flight.rtl", "flight.land", "flight.hold")] == [tool]
    aborted = next(e for e in out["log"] if e.get("step") == "__abort__")
    assert aborted["action"] == (on_abort or "rtl") and aborted["after"] == ["risky"]


GROUND = {"landed_state": "on_ground", "armed": False, "alt_m": 0.0}
SPINNING_UP = {"landed_state": "takeoff", "armed": True, "alt_m": 0.3}
FLYING = {"landed_state": "in_air", "armed": True, "alt_m": 20.0}


@pytest.mark.parametrize(
    ("policy", "on_abort", "vehicle", "sent", "result"),
    [
        ("abort", "rtl", GROUND, [], "not needed"),
        ("rtl", None, GROUND, [], "not needed"),
        ("abort", "rtl", SPINNING_UP, ["flight.land"], "ok"),
        ("rtl", None, SPINNING_UP, ["flight.land"], "ok"),
        ("abort", "hold", SPINNING_UP, ["flight.hold"], "ok"),
        ("abort", "rtl", FLYING, ["flight.rtl"], "ok"),
        ("rtl", None, FLYING, ["flight.rtl"], "ok"),
    ],
)
def test_an_abort_or_return_on_the_ground_never_asks_for_a_take_off(
    policy: str, on_abort: str | None, vehicle: dict[str, Any], sent: list[str], result: str
) -> None:
    """A step failing on the ground (a wait that timed out before take-off): a return would need a take-off, which
    the vehicle denies ("Return denied: not flying") and the run reported as a tool error. Disarmed, nothing is
    sent; armed (spinning up), the aircraft lands in place; in the air, the mission's own choice."""
    rec = Recorder({"svc.flaky": flaky(99)})
    text = POLICY.replace("POLICY", policy).replace("on_abort: hold\n", f"on_abort: {on_abort}\n" if on_abort else "")
    out = run(text, rec, env={"vehicle": lambda: vehicle})
    assert [t for t in rec.tools() if t in ("flight.rtl", "flight.land", "flight.hold")] == sent
    (last,) = [e for e in out["log"] if e.get("step") in ("__abort__", "__rtl__")]
    assert last.get("result", last.get("status")) == result and last.get("error") is None


def test_reflection_splices_revised_steps_and_dependents_wait_for_them() -> None:
    seen: list[Failure] = []

    def reflector(failure: Failure) -> list[dict[str, Any]]:
        seen.append(failure)
        return [
            {"id": "wait_out_wind", "action": "hover", "args": {"duration_s": 30}},
            {
                "id": "low_approach",
                "action": "fly_to",
                "depends_on": ["wait_out_wind"],
                "args": {"lat": 21.4141, "lon": 39.8952, "alt_m": 15},
            },
        ]

    rec = Recorder({"weather.get_forecast": weather(20)})
    out = run((MISSIONS / "inspect_perimeter.yaml").read_text(), rec, reflector=reflector)
    assert [f.step.id for f in seen] == ["inspect_anomaly"]
    assert "is false" in seen[0].error
    assert seen[0].state["outputs"]["check_weather"] == {"current": {"wind_speed_mps": 20}}
    assert rec.tools()[2:] == ["flight.hover", "flight.fly_to", "perception.analyze_scene", "flight.rtl"]
    assert rec.calls[3][1]["alt_m"] == 15
    assert out["status"]["inspect_anomaly"] == "replaced"
    assert out["status"]["look"] == "ok" and out["status"]["go_home"] == "ok"
    assert out.get("halt") is None


def test_an_invalid_revision_is_rejected_and_the_mission_aborts() -> None:
    rec = Recorder({"weather.get_forecast": weather(20)})
    out = run(
        (MISSIONS / "inspect_perimeter.yaml").read_text(),
        rec,
        reflector=lambda f: [{"id": "x", "action": "teleport"}],
    )
    assert out["halt"] == "abort"
    assert any(e.get("status") == "revision rejected" for e in out["log"])


APPROVAL = """
plan_id: approval
goal: land near people only when approved
steps:
  - {id: up, action: takeoff}
  - {id: down, action: land, depends_on: [up], approval: true, on_fail: rtl}
"""


def test_approval_pauses_for_the_operator_and_resumes() -> None:
    rec = Recorder()
    plan = load_mission(APPROVAL, file="a.yaml")
    app = compile_mission(plan, Environment(rec), checkpointer=InMemorySaver())
    cfg = {"configurable": {"thread_id": "t"}}
    paused = app.invoke(initial_state(plan), cfg)
    assert paused["__interrupt__"][0].value["step"] == "down" and rec.tools() == ["flight.takeoff"]
    out = app.invoke(Command(resume="approve"), cfg)
    assert rec.tools() == ["flight.takeoff", "flight.land"] and out["status"]["down"] == "ok"


@pytest.mark.parametrize(("answer", "lands"), [(True, True), (False, False)])
def test_headless_approval_policy(answer: bool, lands: bool) -> None:
    rec = Recorder()
    out = run(APPROVAL, rec, env={"approve": lambda request: answer})
    assert ("flight.land" in rec.tools()) is lands
    if not lands:
        assert "did not approve" in out["errors"]["down"] and out["halt"] == "rtl"


@pytest.mark.parametrize("severity", ["critical", "low"])
def test_emergency_trigger_preempts_the_patrol_and_runs_its_sub_plan(severity: str) -> None:
    world: dict[str, Any] = {"objects": [], "relations": []}
    vehicle = {"landed_state": "on_ground"}
    scans = [0]

    def scan(args: dict[str, Any]) -> Result:
        if args.get("focus"):  # the confirmation, after hovering over the person
            assessment = {"severity": severity, "surrounding_features": "Lying still.", "rationale": "r"}
            return Result("ok", {"assessment": assessment})
        scans[0] += 1
        if scans[0] == 3:  # the third look finds someone motionless, apart from the crowd
            world["objects"] = [
                {"id": "P-12", "class": "person", "stationary_s": 3.0, "pose": {"lat": 21.4121, "lon": 39.8941}}
            ]
            world["relations"] = [{"subj": "P-12", "pred": "isolated_from", "obj": "crowd"}]
        return Result("ok", {"persons": len(world["objects"])})

    def fly(state: str) -> Callable[[dict[str, Any]], Result]:
        def act(args: dict[str, Any]) -> Result:
            vehicle["landed_state"] = state
            return Result("ok", {"status": "ok", "reached": True})

        return act

    script = {"perception.analyze_scene": scan, "flight.land": fly("on_ground"), "flight.takeoff": fly("in_air")}
    rec = Recorder(script)
    plan = load_mission(MISSIONS / "hajj_emergency.yaml")
    env = Environment(rec, world=lambda: world, vehicle=lambda: vehicle, approve=lambda r: "approve")
    out = compile_mission(plan, env).invoke(initial_state(plan), {"recursion_limit": 500})
    assert out["fired"] == ["collapsed_person"]
    tools = rec.tools()
    assert all(out["status"][s] == "ok" for s in ("approach", "observe", "confirm"))
    if severity == "low":  # a false alarm: logged, no landing, and the patrol goes on to the end
        assert "flight.land" not in tools and "alerts.notify" not in tools and "incidents.log" in tools
        assert out["status"]["patrol"] == "ok" and out["status"]["go_home"] == "ok" and tools[-1] == "flight.rtl"
        return
    assert out["status"]["patrol"] == "preempted" and out["status"]["go_home"] == "preempted"
    assert tools.index("alerts.notify") < tools.index("flight.land") < tools.index("flight.deploy_payload")
    assert tools[-2:] == ["flight.takeoff", "flight.rtl"] and "incidents.log" not in tools
    land = dict(rec.calls)["flight.land"]
    assert land == {"target_id": "P-12", "offset_m": 5.0}
    notify = dict(rec.calls)["alerts.notify"]
    assert (
        notify["subject"] == "Collapsed pilgrim P-12 at 21.4121, 39.8941" and notify["to"] == "medical-team@example.org"
    )
    assert all(out["status"][s] == "ok" for s in ("land_near", "release_kit", "alert_medics", "lift_off", "back_home"))


def test_patrol_repeats_its_rounds_then_goes_home() -> None:
    rec = Recorder()
    out = run((MISSIONS / "hajj_patrol.yaml").read_text(), rec)
    assert rec.tools().count("flight.fly_to") == 4  # 2 rounds x 2 gates
    assert rec.tools().count("incidents.log") == 4
    assert rec.tools()[-1] == "flight.rtl"
    assert out["outputs"]["patrol"]["iterations"] == 2 and out["status"]["patrol"] == "ok"


BRANCH = """
plan_id: branch
goal: choose
params: {low_battery: {type: boolean, default: false}}
steps:
  - id: choose
    action: branch
    if: "params.low_battery"
    then: [{id: home, action: rtl}]
    else: [{id: look, action: hover, args: {duration_s: 3}}]
"""


@pytest.mark.parametrize(("low", "tool"), [(True, "flight.rtl"), (False, "flight.hover")])
def test_branch(low: bool, tool: str) -> None:
    rec = Recorder()
    plan = load_mission(BRANCH, file="b.yaml")
    app = compile_mission(plan, Environment(rec))
    app.invoke(initial_state(plan, {"low_battery": low}))
    assert rec.tools() == [tool]


SURVEY = """
plan_id: survey
goal: cover a square
steps:
  - id: cover
    action: survey
    args:
      polygon: [{lat: 21.42, lon: 39.82}, {lat: 21.42, lon: 39.83}, {lat: 21.43, lon: 39.83}, {lat: 21.43, lon: 39.82}]
      altitude_m: 40
      spacing_m: 200
"""


def test_survey_flies_its_lawnmower_legs() -> None:
    rec = Recorder()
    run(SURVEY, rec)
    square = [(21.42, 39.82), (21.42, 39.83), (21.43, 39.83), (21.43, 39.82)]
    expected = lawnmower(square, 200)
    assert len(expected) >= 4
    assert [(a["lat"], a["lon"]) for _, a in rec.calls] == expected
    assert all(tool == "flight.fly_to" and a["alt_m"] == 40 for tool, a in rec.calls)


WAIT = """
plan_id: wait
goal: wait for the battery
steps:
  - {id: charge, action: wait_until, condition: "vehicle.battery_pct >= 90", timeout_s: 60, poll_s: 10}
"""


def test_wait_until_polls_and_times_out() -> None:
    clock = [0.0]
    battery = {"battery_pct": 50}

    def sleep(s: float) -> None:
        clock[0] += s
        battery["battery_pct"] += 10

    env = {"vehicle": lambda: battery, "clock": lambda: clock[0], "sleep": sleep}
    assert run(WAIT, Recorder(), env=env)["status"]["charge"] == "ok"
    assert clock[0] == 40  # 50 % + 4 polls of 10 s
    clock[0], battery["battery_pct"] = 0.0, 10
    out = run(WAIT, Recorder(), env=env)
    assert out["status"]["charge"] == "failed" and "still false after 60 s" in out["errors"]["charge"]


def test_parameters_are_typed_and_checked() -> None:
    plan = load_mission(MISSIONS / "hajj_patrol.yaml")
    assert initial_state(plan, {"rounds": "3"})["params"]["rounds"] == 3
    with pytest.raises(ValueError, match="is an integer, not 'x'"):
        initial_state(plan, {"rounds": "x"})
    with pytest.raises(ValueError, match="at least 1"):
        initial_state(plan, {"rounds": "0"})
    with pytest.raises(ValueError, match="unknown parameter 'round'"):
        initial_state(plan, {"round": "3"})


def weather_registry() -> Any:
    """A registry holding a weather tool of the built-in's signature."""
    from tools import ToolRegistry

    registry = ToolRegistry()

    @registry.tool(name="weather.get_forecast")
    def forecast(lat: float, lon: float, hours: int = 24) -> dict[str, float]:
        return {"wind_mps": 3.0}

    return registry


def test_call_tool_tools_are_checked_against_a_registry_when_one_is_given() -> None:
    from agentic_core.mission import MissionError

    registry = weather_registry()
    text = (MISSIONS / "inspect_perimeter.yaml").read_text()
    assert load_mission(text, tools=registry).plan_id == "P-789"
    with pytest.raises(MissionError) as err:
        load_mission(text.replace("weather.get_forecast", "weather.get_forcast"), file="p.yaml", tools=registry)
    (problem,) = err.value.problems
    assert (problem.line, problem.message) == (
        31,
        "unknown tool 'weather.get_forcast': no such tool is registered; did you mean 'weather.get_forecast'?",
    )


def test_call_tool_arguments_written_in_the_mission_are_checked_against_the_tool_schema() -> None:
    from agentic_core.mission import MissionError

    registry = weather_registry()
    text = (MISSIONS / "inspect_perimeter.yaml").read_text()
    broken = text.replace(
        'args: {lat: "${params.anomaly_lat}", lon: "${params.anomaly_lon}"}',
        'args: {lat: "${params.anomaly_lat}", hours: "soon"}',
    )
    assert broken != text
    with pytest.raises(MissionError) as err:
        load_mission(broken, file="p.yaml", tools=registry)
    messages = sorted((p.line, p.message) for p in err.value.problems)
    assert messages == [
        (32, "weather.get_forecast: 'lon' is a required property"),
        (32, "weather.get_forecast: 'soon' is not of type 'integer'"),
    ]
