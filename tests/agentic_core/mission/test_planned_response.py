"""A trigger with ``plan: reasoner``: the reasoner's plan runs when it passes the same checks as a mission, the
trigger's own steps otherwise, and every refusal is in the mission's log with its reasons."""

from typing import Any

import pytest

from agentic_core.mission import Environment, compile_mission, initial_state, load_mission

from .test_compile import Recorder, Result, run, weather_registry

PLANNED = """
plan_id: p
goal: help whoever lies still
limits: {max_altitude_m: 60, geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 800}}
steps:
  - {id: up, action: takeoff}
  - {id: look, action: hover, depends_on: [up], args: {duration_s: 1}}
triggers:
  - id: casualty
    when: "find(world, class_='person')"
    plan: reasoner
    steps:
      - {id: playbook_alert, action: notify, args: {to: medics@example.org, subject: "${event.id}", body: b}}
"""
WORLD = {"objects": [{"id": "P-1", "class": "person"}], "relations": []}


def planned(steps: Any, review: Any = None) -> tuple[Recorder, dict[str, Any], list[tuple[str, str]]]:
    asked: list[tuple[str, str]] = []

    def planner(trigger: Any, event: Any) -> Any:
        asked.append((trigger.id, event["id"]))
        if isinstance(steps, Exception):
            raise steps
        return steps

    rec = Recorder()
    env: dict[str, Any] = {"world": lambda: WORLD, "planner": planner, "review": review}
    return rec, run(PLANNED, rec, env=env), asked


def entries(out: dict[str, Any], status: str) -> list[dict[str, Any]]:
    return [e for e in out["log"] if e.get("status") == status]


def test_the_reasoners_plan_runs_instead_of_the_triggers_steps() -> None:
    plan = [
        {"id": "go_see", "action": "fly_to", "args": {"target_id": "${event.id}", "alt_m": 15}},
        {
            "id": "tell",
            "action": "notify",
            "depends_on": ["go_see"],
            "args": {"to": "m@example.org", "subject": "s", "body": "x"},
        },
    ]
    rec, out, asked = planned(plan)
    assert asked == [("casualty", "P-1")]
    assert rec.tools() == ["flight.takeoff", "flight.fly_to", "alerts.notify", "flight.hover"]  # then the plan goes on
    assert rec.calls[1][1]["target_id"] == "P-1"
    assert entries(out, "planned") == [{"step": "casualty", "status": "planned", "by": ["go_see", "tell"]}]
    assert out["status"]["go_see"] == "ok" and "playbook_alert" not in out["status"]


@pytest.mark.parametrize(
    ("steps", "reason"),
    [
        ([{"id": "x", "action": "teleport"}], "mission language"),
        ([{"id": "far", "action": "fly_to", "args": {"lat": 21.5, "lon": 39.8933}}], "geofence"),
        ([{"id": "high", "action": "fly_to", "args": {"north_m": 0, "east_m": 0, "alt_m": 500}}], "ceiling"),
        ([{"id": "x", "action": "call_tool", "tool": "nope.nothing"}], "unknown tool"),
        ([{"id": "up", "action": "hover", "args": {"duration_s": 1}}], "up"),  # reuses the mission's id
    ],
)
def test_a_plan_the_checks_refuse_is_logged_and_the_triggers_steps_run(steps: Any, reason: str) -> None:
    rec = Recorder()
    plan = load_mission(PLANNED, file="p.yaml")
    env: dict[str, Any] = {"world": lambda: WORLD, "planner": lambda t, e: steps}
    app = compile_mission(plan, Environment(rec, **env), tools=weather_registry() if "tool" in reason else None)
    out: dict[str, Any] = app.invoke(initial_state(plan), {"recursion_limit": 500})
    refused = entries(out, "plan rejected")
    assert len(refused) == 1 and reason in refused[0]["error"], refused
    assert out["status"]["playbook_alert"] == "ok" and rec.tools() == [
        "flight.takeoff",
        "alerts.notify",
        "flight.hover",
    ]


def test_the_runners_review_is_part_of_the_checks() -> None:
    def review(steps: list[Any]) -> list[str]:
        return [f"step {s.id!r}: {s.action} needs approval: true" for s in steps if s.action == "land"]

    rec, out, _ = planned([{"id": "down", "action": "land", "args": {"target_id": "P-1"}}], review)
    assert "down" in entries(out, "plan rejected")[0]["error"] and "flight.land" not in rec.tools()
    assert out["status"]["playbook_alert"] == "ok"


@pytest.mark.parametrize("answer", [None, [], RuntimeError("model unreachable")])
def test_no_plan_or_a_failing_planner_runs_the_triggers_steps(answer: Any) -> None:
    _, out, asked = planned(answer)
    assert asked and out["status"]["playbook_alert"] == "ok"
    if isinstance(answer, Exception):
        assert "model unreachable" in entries(out, "plan failed")[0]["error"]
    else:
        assert entries(out, "plan empty")


def test_a_trigger_that_does_not_ask_for_a_plan_never_calls_the_planner() -> None:
    rec = Recorder()
    asked: list[Any] = []

    def planner(trigger: Any, event: Any) -> list[dict[str, Any]]:
        asked.append(trigger)
        return []

    text = PLANNED.replace("    plan: reasoner\n", "")
    out = run(text, rec, env={"world": lambda: WORLD, "planner": planner})
    assert asked == [] and out["status"]["playbook_alert"] == "ok"


def test_a_planned_step_that_fails_goes_to_reflection_like_any_other() -> None:
    rec = Recorder({"svc.flaky": lambda args: Result("error", error="down")})
    revised: list[str] = []

    def reflector(failure: Any) -> list[dict[str, Any]]:
        revised.append(failure.step.id)
        return [{"id": "instead", "action": "hover", "args": {"duration_s": 1}}]

    plan = [{"id": "try", "action": "call_tool", "tool": "svc.flaky", "on_fail": "trigger_reflection"}]
    out = run(PLANNED, rec, env={"world": lambda: WORLD, "planner": lambda t, e: plan}, reflector=reflector)
    assert revised == ["try"] and out["status"]["try"] == "replaced" and out["status"]["instead"] == "ok"
