"""Edge cases of running missions, each found in review and fixed: halts that stop parallel work, steps that
must run exactly once, splices that compose, pre-emption that resumes the plan, a dispatcher that raises."""

from collections.abc import Callable
from typing import Any

import pytest

from agentic_core.graph import Command, InMemorySaver
from agentic_core.mission import Environment, MissionError, compile_mission, initial_state, load_mission

from .test_compile import Recorder, Result, flaky, run

BOOM = {"svc.check": lambda args: Result("error", error="boom")}


@pytest.mark.parametrize("policy", ["abort", "rtl"])
def test_a_halting_failure_stops_what_would_start_beside_it(policy: str) -> None:
    rec = Recorder(BOOM)
    out = run(
        f"""
plan_id: p
goal: g
on_abort: hold
steps:
  - {{id: check, action: call_tool, tool: svc.check, on_fail: {policy}}}
  - {{id: up, action: takeoff}}
  - {{id: go, action: fly_to, depends_on: [up], args: {{north_m: 100, east_m: 0}}}}
""",
        rec,
    )
    assert "flight.fly_to" not in rec.tools()
    assert out["halt"] == policy and out["status"]["go"] == "cancelled"
    assert ("flight.rtl" in rec.tools()) is (policy == "rtl")


def test_a_step_whose_id_sorts_before_the_scheduler_runs_once() -> None:
    rec = Recorder()
    run(
        """
plan_id: p
goal: g
steps:
  - {id: climb, action: takeoff}
  - id: patrol
    action: repeat
    depends_on: [climb]
    until: "patrol.iterations >= 2"
    steps: [{id: look, action: hover, args: {duration_s: 1}}]
  - {id: GoHome, action: rtl, depends_on: [patrol]}
""",
        rec,
    )
    assert rec.tools().count("flight.rtl") == 1


GATED = """
plan_id: p
goal: g
steps:
  - {id: a, action: hover, args: {duration_s: 1}}
  - {id: b, action: hover, depends_on: [a], args: {duration_s: 1}}
  - {id: c, action: hover, depends_on: [b], args: {duration_s: 1}}
triggers:
  - id: t
    when: "find(world, class_='person')"
    once: false
    preempt: false
    steps: [{id: warn, action: notify, args: {subject: "${event.id}", body: seen}}]
"""


def another_person_on_the_second_leg(world: dict[str, Any]) -> Callable[[dict[str, Any]], Result]:
    """A hover that finds P-1 replaced by P-2 in ``world`` when it is flown the second time."""
    legs = [0]

    def hover(args: dict[str, Any]) -> Result:
        legs[0] += 1
        if legs[0] == 2:
            world["objects"] = [{"id": "P-2", "class": "person"}]
        return Result("ok", {})

    return hover


def test_a_trigger_that_may_fire_again_does_so_for_a_new_event_under_fresh_ids() -> None:
    world: dict[str, Any] = {"objects": [{"id": "P-1", "class": "person"}], "relations": []}
    rec = Recorder({"flight.hover": another_person_on_the_second_leg(world)})
    out = run(GATED, rec, env={"world": lambda: world})
    subjects = [args["subject"] for tool, args in rec.calls if tool == "alerts.notify"]
    assert subjects == ["P-1", "P-2"]
    assert out["status"]["warn"] == "ok" and out["status"]["warn_2"] == "ok"


VERDICTS = GATED.replace(
    """    steps: [{id: warn, action: notify, args: {subject: "${event.id}", body: seen}}]""",
    """    steps:
      - {id: look, action: hover, args: {duration_s: 2}}
      - id: warn
        action: notify
        depends_on: [look]
        preconditions: ["look.verdict == 'real'"]
        on_fail: skip
        args: {subject: "${event.id} ${look.verdict}", body: "${steps.look.verdict}"}""",
)


def test_a_trigger_fired_again_reads_its_own_steps_not_the_first_firings() -> None:
    """The emergency mission's shape: a look, then steps whose preconditions read its verdict. The first person
    is a false alarm, the second is real: the second firing's steps must read the second look (``look`` in its
    expressions is ``look_2``), or a real casualty after a false alarm is skipped on the old verdict."""
    world: dict[str, Any] = {"objects": [{"id": "P-1", "class": "person"}], "relations": []}
    verdicts, leg = iter(["false alarm", "real"]), another_person_on_the_second_leg(world)

    def hover(args: dict[str, Any]) -> Result:
        return Result("ok", {"verdict": next(verdicts)}) if args["duration_s"] == 2 else leg(args)

    rec = Recorder({"flight.hover": hover})
    out = run(VERDICTS, rec, env={"world": lambda: world})
    sent = [(args["subject"], args["body"]) for tool, args in rec.calls if tool == "alerts.notify"]
    assert sent == [("P-2 real", "real")]
    assert out["status"]["warn"] == "skipped" and out["status"]["warn_2"] == "ok"


def test_in_a_firing_again_the_written_ids_name_its_own_steps_in_every_root() -> None:
    from agentic_core.mission.steps import ALIASES, DECLINED, scope

    state = {
        "outputs": {"look": {"verdict": "old"}, "look_2": {"verdict": "new"}, "route": {"km": 3}},
        "status": {"look": "ok", "look_2": "ok", "land": "failed", "route": "ok"},
        "errors": {"land": f"{DECLINED} land", "drop_2": f"{DECLINED} drop_2"},
        ALIASES: {"look": "look_2", "land": "land_2", "drop": "drop_2"},
    }
    where = scope(state, Environment(Recorder()))
    assert where["look"] == where["steps"]["look"] == {"verdict": "new"} and where["route"] == {"km": 3}
    assert "land" not in where and where["mission"]["status"] == {"look": "ok", "look_2": "ok", "route": "ok"}
    assert where["mission"]["declined"] == ["drop"]  # this firing's, as written; the first firing's land is not


def test_approval_is_asked_once_even_with_retries() -> None:
    rec = Recorder({"flight.deploy_payload": flaky(1)})
    plan = load_mission(
        "plan_id: p\ngoal: g\nsteps:\n  - {id: drop, action: deploy_payload, approval: true, max_retries: 1}\n",
        file="t.yaml",
    )
    app = compile_mission(plan, Environment(rec), checkpointer=InMemorySaver())
    cfg = {"configurable": {"thread_id": "t"}}
    assert app.invoke(initial_state(plan), cfg)["__interrupt__"]
    out = app.invoke(Command(resume="approve"), cfg)
    assert rec.tools() == ["flight.deploy_payload", "flight.deploy_payload"]  # two attempts, one approval
    assert out["status"]["drop"] == "ok"


def test_a_repeat_checks_its_preconditions_before_its_first_pass() -> None:
    rec = Recorder()
    out = run(
        """
plan_id: p
goal: g
steps:
  - id: patrol
    action: repeat
    preconditions: ["vehicle.battery_pct > 50"]
    until: "patrol.iterations >= 2"
    steps: [{id: leg, action: fly_to, args: {north_m: 10, east_m: 0}}]
""",
        rec,
        env={"vehicle": lambda: {"battery_pct": 10}},
    )
    assert rec.tools() == ["flight.rtl"] and "is false" in out["errors"]["patrol"]  # aborted: on_abort (rtl)


def test_a_dispatcher_that_raises_fails_the_step_and_its_policy_applies() -> None:
    def broken(args: dict[str, Any]) -> Result:
        raise ConnectionError("link down")

    rec = Recorder({"svc.x": broken})
    out = run("plan_id: p\ngoal: g\nsteps:\n  - {id: ask, action: call_tool, tool: svc.x, on_fail: rtl}\n", rec)
    assert out["errors"]["ask"].startswith("svc.x raised ConnectionError: link down")
    assert out["halt"] == "rtl" and rec.tools()[-1] == "flight.rtl"


def reflector_fixing() -> Any:
    def reflect(failure: Any) -> list[dict[str, Any]]:
        return [{"id": f"{failure.step.id}_fix", "action": "hover", "args": {"duration_s": 1}}]

    return reflect


def test_several_reflections_in_one_superstep_compose() -> None:
    rec = Recorder({"svc.a": flaky(9), "svc.b": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: a, action: call_tool, tool: svc.a, on_fail: trigger_reflection}
  - {id: b, action: call_tool, tool: svc.b, on_fail: trigger_reflection}
  - {id: c, action: land, depends_on: [a, b]}
""",
        rec,
        reflector=reflector_fixing(),
    )
    assert out["waits_for"]["c"] == ["a_fix", "b_fix"]
    assert out["status"]["c"] == "ok" and rec.tools()[-1] == "flight.land"


def test_a_replacement_can_itself_be_replaced() -> None:
    answers = iter(
        [
            [{"id": "fix1", "action": "call_tool", "tool": "svc.a", "on_fail": "trigger_reflection"}],
            [{"id": "fix2", "action": "hover", "args": {"duration_s": 1}}],
        ]
    )
    rec = Recorder({"svc.a": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: a, action: call_tool, tool: svc.a, on_fail: trigger_reflection}
  - {id: c, action: land, depends_on: [a]}
""",
        rec,
        reflector=lambda failure: next(answers),
    )
    assert out["status"] == {"a": "replaced", "fix1": "replaced", "fix2": "ok", "c": "ok"}


def test_a_revision_may_not_reuse_an_id_of_the_mission() -> None:
    rec = Recorder({"svc.a": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: a, action: call_tool, tool: svc.a, on_fail: trigger_reflection}
triggers:
  - {id: t, when: "false", steps: [{id: help, action: hover, args: {duration_s: 1}}]}
""",
        rec,
        reflector=lambda failure: [{"id": "help", "action": "hover", "args": {"duration_s": 2}}],
    )
    assert out["halt"] == "abort"
    assert any("step id 'help' is already in the mission" in str(e.get("error")) for e in out["log"])


def test_dependencies_given_for_trigger_steps_are_kept() -> None:
    rec = Recorder()
    run(
        """
plan_id: p
goal: g
steps:
  - {id: up, action: takeoff}
triggers:
  - id: t
    when: "true"
    preempt: false
    steps:
      - {id: approach, action: fly_to, args: {north_m: 1, east_m: 1}}
      - {id: drop, action: deploy_payload}
dependencies: {drop: [approach]}
""",
        rec,
    )
    tools = rec.tools()
    assert tools.index("flight.fly_to") < tools.index("flight.deploy_payload")


def test_a_preempting_trigger_pauses_the_plan_which_goes_on_unless_the_sub_plan_landed() -> None:
    rec = Recorder()
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: up, action: takeoff}
  - {id: look, action: hover, depends_on: [up], args: {duration_s: 1}}
  - {id: home, action: rtl, depends_on: [look]}
triggers:
  - {id: t, when: "true", steps: [{id: note, action: notify, args: {subject: s, body: b}}]}
""",
        rec,
    )
    assert rec.tools()[-1] == "flight.rtl" and out["status"]["home"] == "ok"


def test_bad_survey_values_fail_the_step_not_the_mission() -> None:
    rec = Recorder()
    out = run(
        """
plan_id: p
goal: g
params: {spacing: {default: 0}}
steps:
  - id: cover
    action: survey
    args:
      polygon: [{lat: 21.42, lon: 39.82}, {lat: 21.42, lon: 39.83}, {lat: 21.43, lon: 39.83}]
      altitude_m: 40
      spacing_m: "${params.spacing}"
""",
        rec,
    )
    assert out["status"]["cover"] == "failed" and "survey: bad polygon or spacing" in out["errors"]["cover"]


def test_parameters_need_a_value_and_must_be_finite() -> None:
    plan = load_mission("plan_id: p\ngoal: g\nparams: {alt: {}}\nsteps: [{id: up, action: takeoff}]\n", file="t")
    with pytest.raises(ValueError, match="no default and were not given: --param alt"):
        initial_state(plan)
    with pytest.raises(ValueError, match="is a number, not 'nan'"):
        initial_state(plan, {"alt": "nan"})
    assert initial_state(plan, {"alt": "12"})["params"]["alt"] == 12.0


@pytest.mark.parametrize(
    ("steps", "message"),
    [
        ("  - {id: vehicle, action: takeoff}\n", "would hide the expression name"),
        ("  - {id: go, action: fly_to, args: {target_id: '${event.id}'}}\n", "unknown name 'event'"),
        ("  - {id: l, action: land, args: {lat: 21.4}}\n", "lat and lon go together"),
        (
            "  - id: r\n    action: repeat\n    until: 'true'\n    steps:\n"
            "      - {id: x, action: hover, args: {duration_s: 1}}\n"
            "      - {id: y, action: hover, depends_on: [x], args: {duration_s: 1}}\n",
            "depends_on has no meaning there",
        ),
        (
            "  - id: r\n    action: branch\n    if: 'true'\n    then: [{id: x, action: rtl, on_fail: rtl}]\n",
            "on_fail is skip, retry or abort",
        ),
        (
            "  - {id: s, action: survey, args: {altitude_m: 20, spacing_m: 0.5,"
            " polygon: [{lat: 1, lon: 1}, {lat: 1, lon: 2}, {lat: 2, lon: 2}]}}\n",
            "greater than or equal to 1",
        ),
    ],
)
def test_the_validator_catches_what_would_misbehave_at_run_time(steps: str, message: str) -> None:
    with pytest.raises(MissionError) as err:
        load_mission(f"plan_id: p\ngoal: g\nsteps:\n{steps}", file="t.yaml")
    assert any(message in p.message for p in err.value.problems), str(err.value)


@pytest.mark.parametrize(
    "text",
    [
        "plan_id: p\ngoal: g\nparams: {n: {type: integer, default: " + "9" * 401 + ", maximum: 3}}\nsteps: []\n",
        "plan_id: p\ngoal: g\nsteps: [{id: h, action: hover, args: {duration_s: " + "9" * 5000 + "}}]\n",
    ],
)
def test_huge_numbers_are_problems_not_tracebacks(text: str) -> None:
    with pytest.raises(MissionError):
        load_mission(text, file="t.yaml")


@pytest.mark.parametrize(
    ("revision", "why"),
    [
        ({"id": "far", "action": "fly_to", "args": {"lat": 0, "lon": 0}}, "outside the geofence"),
        ({"id": "high", "action": "takeoff", "args": {"altitude_m": 5000}}, "above the ceiling of 60 m"),
        ({"id": "odd", "action": "hover", "preconditions": ["wnd < 3"], "args": {"duration_s": 1}}, "unknown name"),
    ],
)
def test_a_revision_is_checked_like_the_mission_before_it_flies(revision: dict[str, Any], why: str) -> None:
    rec = Recorder({"svc.a": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
limits: {geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 500}, max_altitude_m: 60}
steps:
  - {id: a, action: call_tool, tool: svc.a, on_fail: trigger_reflection}
""",
        rec,
        reflector=lambda failure: [revision],
    )
    assert out["halt"] == "abort" and rec.tools() == ["svc.a", "flight.rtl"]
    assert any(why in str(e.get("error")) for e in out["log"] if e.get("status") == "revision rejected")


def test_a_revision_may_read_outputs_of_the_mission() -> None:
    rec = Recorder({"svc.a": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: up, action: takeoff}
  - {id: a, action: call_tool, tool: svc.a, depends_on: [up], on_fail: trigger_reflection}
""",
        rec,
        reflector=lambda f: [
            {
                "id": "fix",
                "action": "hover",
                "preconditions": ["up.tool == 'flight.takeoff'"],
                "args": {"duration_s": 1},
            }
        ],
    )
    assert out["status"]["fix"] == "ok" and out.get("halt") is None


@pytest.mark.parametrize(
    ("steps", "ok"),
    [
        (
            "  - {id: scan, action: analyze_scene}\n  - {id: go, action: hover, preconditions: ['scan.persons > 0'],"
            " args: {duration_s: 1}}\n",
            False,
        ),
        (
            "  - {id: scan, action: analyze_scene}\n  - {id: go, action: hover, depends_on: [scan],"
            " preconditions: ['steps.scan.persons > 0'], args: {duration_s: 1}}\n",
            True,
        ),
        (
            "  - {id: up, action: takeoff}\n  - {id: scan, action: analyze_scene, depends_on: [up]}\n"
            "  - {id: go, action: hover, depends_on: [scan], preconditions: ['up.tool != 0'], args: {duration_s: 1}}\n",
            True,
        ),
        (
            "  - id: patrol\n    action: repeat\n    until: 'patrol.iterations >= 2 and look.seen'\n    steps:\n"
            "      - {id: look, action: analyze_scene}\n"
            "      - {id: log, action: call_tool, tool: a.b, args: {n: '${look.seen}'}}\n",
            True,
        ),
        (
            "  - id: patrol\n    action: repeat\n    until: 'true'\n    steps:\n"
            "      - {id: log, action: call_tool, tool: a.b, args: {n: '${look.seen}'}}\n"
            "      - {id: look, action: analyze_scene}\n",
            False,
        ),
    ],
)
def test_expressions_may_read_only_steps_they_wait_for(steps: str, ok: bool) -> None:
    text = f"plan_id: p\ngoal: g\nsteps:\n{steps}"
    if ok:
        assert load_mission(text, file="t.yaml")
        return
    with pytest.raises(MissionError) as err:
        load_mission(text, file="t.yaml")
    assert "does not wait for: it may not have run yet" in str(err.value)


def test_a_trigger_step_that_fails_with_rtl_sends_the_aircraft_home() -> None:
    rec = Recorder()
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: up, action: takeoff}
triggers:
  - id: t
    when: "true"
    steps: [{id: land_near, action: land, approval: true, on_fail: rtl}]
""",
        rec,
        env={"approve": lambda request: False},
    )
    assert rec.tools() == ["flight.takeoff", "flight.rtl"] and out["halt"] == "rtl"


def test_two_rtl_failures_at_once_send_one_return_home() -> None:
    rec = Recorder({"svc.a": flaky(9), "svc.b": flaky(9)})
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: a, action: call_tool, tool: svc.a, on_fail: rtl}
  - {id: b, action: call_tool, tool: svc.b, on_fail: rtl}
""",
        rec,
    )
    assert rec.tools().count("flight.rtl") == 1 and out["halt"] == "rtl"


@pytest.mark.parametrize("act", [True, False])
def test_a_trigger_acts_only_when_the_gate_says_so(act: bool) -> None:
    asked: list[str] = []

    def gate(trigger: Any, event: Any) -> bool:
        asked.append(f"{trigger.id}:{event['id']}")
        return act

    rec = Recorder()
    world = {"objects": [{"id": "P-1", "class": "person"}], "relations": []}
    out = run(GATED, rec, env={"world": lambda: world, "gate": gate})
    assert asked and set(asked) == {"t:P-1"}
    assert ("alerts.notify" in rec.tools()) is act
    declined = [e for e in out["log"] if e.get("status") == "declined"]
    assert bool(declined) is not act


def test_the_same_object_is_one_event_though_its_fields_change() -> None:
    """A world-model object's timers and pose change every frame: it is the same person, so no second firing."""
    seconds = [0]

    def look(args: dict[str, Any]) -> Result:
        seconds[0] += 5
        return Result("ok", {})

    def world() -> dict[str, Any]:
        return {"objects": [{"id": "P-1", "class": "person", "stationary_s": seconds[0]}], "relations": []}

    rec = Recorder({"flight.hover": look})
    run(GATED, rec, env={"world": world})
    assert [args["subject"] for tool, args in rec.calls if tool == "alerts.notify"] == ["P-1"]


def test_an_aborted_mission_holds_where_it_is_once() -> None:
    rec = Recorder(BOOM)
    out = run(
        """
plan_id: p
goal: g
steps:
  - {id: up, action: takeoff}
  - {id: check, action: call_tool, tool: svc.check, depends_on: [up]}
  - {id: go, action: fly_to, depends_on: [check], args: {north_m: 100, east_m: 0}}
""",
        rec,
    )
    assert out["halt"] == "abort" and rec.tools() == ["flight.takeoff", "svc.check", "flight.rtl"]
    aborted = next(e for e in out["log"] if e.get("step") == "__abort__")
    assert aborted["action"] == "rtl" and aborted["result"] == "ok"
