"""A command that resolves outside the mission's limits is refused in flight and never reaches the aircraft,
whether the mission wrote it through a template or a model's plan did: the step fails with the envelope's reason
and the aircraft never crosses the fence."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from agentic_core.run.runner import RunSettings, run_mission

from .conftest import NEAR, of_kind, slow_server, telemetry, trace

MISSION = """
plan_id: fence-trap
goal: Fly a leg whose end is written as north/east metres, past the fence.
params:
  north: {type: number, default: 215}
limits:
  geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 200}
  max_altitude_m: 25
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: out, action: fly_to, depends_on: [up], args: {north_m: "${params.north}", east_m: 0, alt_m: 10}}
  - {id: home, action: rtl, depends_on: [out]}
"""


def test_a_templated_north_east_waypoint_past_the_fence_is_refused_in_flight(tmp_path: Path) -> None:
    mission = tmp_path / "trap.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    result = run_mission(
        RunSettings(mission=mission, scene=NEAR, runs_dir=tmp_path / "runs", camera_hz=5.0), progress=None
    )
    records = trace(result.run_dir)
    (refused,) = [r for r in of_kind(records, "tool") if r.get("status") == "denied"]
    assert refused["name"] == "flight.fly_to" and "15 m outside the geofence" in refused["error"]
    assert result.summary.outcome == "aborted"
    farthest = max(math.hypot(t["north_m"], t["east_m"]) for t in telemetry(result.run_dir))
    assert farthest < 201.0, farthest


@pytest.mark.slow
def test_a_model_plan_past_the_fence_is_refused_before_it_flies(tmp_path: Path, smtp: Any) -> None:
    """The emergency mission (a fence of 800 m around home) with a model whose response plan flies 900 m north,
    written in north/east metres, which the static checks cannot place: refused in flight, never sent."""
    server, model = slow_server(0.0)
    model.model.plan = [{"id": "chase", "action": "fly_to", "args": {"north_m": 900, "east_m": 0, "alt_m": 20}}]
    repo = Path(__file__).resolve().parents[3]
    with server:
        result = run_mission(
            RunSettings(
                mission=repo / "missions" / "hajj_emergency.yaml", scene=NEAR, runs_dir=tmp_path / "runs",
                params={"rounds": "1", "still_s": "4"}, reasoner="llm", llm=f"openai-compatible:m@{server.url}/v1",
                camera_hz=5.0,
            ),
            progress=None,
        )  # fmt: skip
    records = trace(result.run_dir)
    assert any(r["status"] == "planned" for r in of_kind(records, "mission"))  # the plan passed the static checks
    (denied,) = [r for r in of_kind(records, "tool") if r.get("status") == "denied"]
    assert denied["args"]["north_m"] == 900 and "100 m outside the geofence" in denied["error"]
    farthest = max(math.hypot(t["north_m"], t["east_m"]) for t in telemetry(result.run_dir))
    assert farthest < 801.0


LOW_CEILING = """
plan_id: low-ceiling
goal: Out and home under a 25 m ceiling; the vehicle's own return must stay under it too.
limits:
  geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 200}
  max_altitude_m: 25
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: out, action: fly_to, depends_on: [up], args: {north_m: 120, east_m: 0, alt_m: 10}}
  - {id: home, action: rtl, depends_on: [out]}
"""


@pytest.mark.slow
def test_the_vehicle_is_given_the_mission_limits_and_returns_under_the_ceiling(tmp_path: Path) -> None:
    mission = tmp_path / "low.yaml"
    mission.write_text(LOW_CEILING, encoding="utf-8")
    result = run_mission(
        RunSettings(mission=mission, scene=NEAR, runs_dir=tmp_path / "runs", camera_hz=5.0), progress=None
    )
    assert result.summary.outcome == "completed"
    records = trace(result.run_dir)
    (fence,) = [r for r in of_kind(records, "tool") if r.get("name") == "flight.set_fence"]
    assert fence["status"] == "ok"
    tools = [r["name"] for r in of_kind(records, "tool") if r.get("status") == "ok"]
    assert tools.index("flight.set_fence") < tools.index("flight.takeoff")  # before anything flies
    samples = telemetry(result.run_dir)
    assert max(t["alt_m"] for t in samples) < 25.0  # PX4's return would climb to its RTL_RETURN_ALT (60 m)
    assert samples[-1]["alt_m"] < 0.5 and math.hypot(samples[-1]["north_m"], samples[-1]["east_m"]) < 3.0
