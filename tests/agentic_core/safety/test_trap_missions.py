"""The four trap missions of ``missions/examples/``, flown end to end on the simulator and judged from the telemetry
they leave: every waypoint within 2.5 m, never more than 1 m outside the fence or above the ceiling, landed within
3 m of home; the fence trap refused in flight, the battery trap home within 20 s with no further survey point."""

from __future__ import annotations

from pathlib import Path

from agentic_core.contracts.faults import parse_fault
from agentic_core.contracts.policy_graph import step_args
from agentic_core.mission.validate import load_mission

from .conftest import EXAMPLES, WAYPOINT_M, assert_safe_and_home, fly, judge, of_kind, records


def _waypoints(mission: Path) -> list[tuple[float, float]]:
    """The mission's fly_to points (north, east) from home."""
    points = []
    for step in load_mission(mission).steps:
        args = step_args(step)
        if step.action == "fly_to":
            points.append((float(args["north_m"]), float(args["east_m"])))
    return points


def test_three_waypoints_at_10_m_then_home(tmp_path: Path) -> None:
    mission = EXAMPLES / "waypoints_home.yaml"
    result = fly(mission, tmp_path)
    assert result.summary.outcome == "completed"
    judged = judge(result.run_dir, mission)
    for north, east in _waypoints(mission):
        assert judged.closest(north, east) <= WAYPOINT_M, (north, east)
    legs = [
        s for s in judged.samples if s["mode"] not in ("rtl", "land") and s["north_m"] ** 2 + s["east_m"] ** 2 > 400
    ]
    assert legs and max(abs(s["alt_m"] - 10.0) for s in legs) < 1.5  # the legs were flown at 10 m (the return higher)
    assert_safe_and_home(judged)


def test_a_20_m_square_at_15_m(tmp_path: Path) -> None:
    mission = EXAMPLES / "square_15m.yaml"
    result = fly(mission, tmp_path)
    assert result.summary.outcome == "completed"
    judged = judge(result.run_dir, mission)
    for north, east in _waypoints(mission):
        assert judged.closest(north, east) <= WAYPOINT_M, (north, east)
    assert_safe_and_home(judged)


def test_a_templated_waypoint_past_the_fence_is_refused_in_flight_and_the_aircraft_comes_home(tmp_path: Path) -> None:
    mission = EXAMPLES / "fence_trap.yaml"
    result = fly(mission, tmp_path)
    trace = records(result.run_dir, "trace.jsonl")
    (refused,) = [r for r in of_kind(trace, "tool") if r.get("status") == "denied"]
    assert refused["name"] == "flight.fly_to" and "outside the geofence" in refused["error"]
    assert not [r for r in of_kind(trace, "tool") if r.get("name") == "flight.fly_to" and r.get("status") == "ok"]
    assert result.summary.outcome == "aborted"
    assert_safe_and_home(judge(result.run_dir, mission))


def test_the_battery_dropped_to_18_percent_at_the_first_survey_point_returns_home(tmp_path: Path) -> None:
    mission = EXAMPLES / "battery_survey.yaml"
    result = fly(mission, tmp_path, faults=[parse_fault("battery=18%@S1")])
    trace = records(result.run_dir, "trace.jsonl")
    (fault,) = of_kind(trace, "fault")
    assert fault["status"] == "ok" and fault["fault"] == "battery=18%@S1"
    arrived = next(r for r in of_kind(trace, "step") if r["step"] == "S1" and r["status"] == "ok")
    assert fault["seq"] > arrived["seq"]  # delivered once the aircraft was at the first point
    (failsafe,) = [r for r in of_kind(trace, "failsafe") if r.get("by") == "agent"]
    assert failsafe["failsafe"] == "battery" and failsafe["action"] == "rtl" and failsafe["battery_pct"] < 25
    judged = judge(result.run_dir, mission)
    returning = min(s["time_s"] for s in judged.samples if s["mode"] == "rtl")
    assert 0 <= returning - fault["sim_t"] < 20.0
    later = [r for r in of_kind(trace, "tool") if r.get("name") == "flight.fly_to" and r.get("status") == "ok"]
    assert [r["sim_t"] for r in later if r["sim_t"] > failsafe["sim_t"]] == []  # no further survey point
    s2 = _waypoints(mission)[1]
    assert judged.closest(*s2) > 20.0
    assert result.summary.outcome == "returned"
    assert_safe_and_home(judged)
    report = result.report.read_text(encoding="utf-8")
    assert "## Failsafes" in report and "battery=18%@S1 injected" in report and "below the mission's 25%" in report
