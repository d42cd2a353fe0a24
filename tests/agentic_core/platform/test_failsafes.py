"""The mission's ``min_battery_pct`` acts on telemetry: once the battery falls below it in the air, the agent
stops the mission and returns home — no scene, no reasoner — and the trace says why."""

from __future__ import annotations

import math
from pathlib import Path

from agentic_core.run.runner import RunSettings, run_mission

from .conftest import of_kind, telemetry, trace

SURVEY = """
plan_id: battery-trap
goal: Four points of a survey; home when the battery is below the limit.
limits:
  geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 400}
  max_altitude_m: 40
  min_battery_pct: 99.2
steps:
  - {id: up, action: takeoff, args: {altitude_m: 15}}
  - {id: s1, action: fly_to, depends_on: [up], args: {north_m: 150, east_m: 0, alt_m: 15}}
  - {id: s2, action: fly_to, depends_on: [s1], args: {north_m: 150, east_m: 150, alt_m: 15}}
  - {id: s3, action: fly_to, depends_on: [s2], args: {north_m: 0, east_m: 150, alt_m: 15}}
  - {id: s4, action: fly_to, depends_on: [s3], args: {north_m: 0, east_m: 0, alt_m: 15}}
"""


def test_a_battery_below_the_mission_limit_sends_the_aircraft_home(tmp_path: Path) -> None:
    mission = tmp_path / "battery.yaml"
    mission.write_text(SURVEY, encoding="utf-8")
    result = run_mission(RunSettings(mission=mission, runs_dir=tmp_path / "runs"), progress=None)
    records = trace(result.run_dir)
    (failsafe,) = of_kind(records, "failsafe")
    assert failsafe["failsafe"] == "battery" and failsafe["battery_pct"] < 99.2
    (command,) = of_kind(records, "control")
    assert command["command"] == "rtl" and command["by"] == "failsafe"
    flown = [r for r in of_kind(records, "tool") if r.get("status") == "ok"]
    samples = telemetry(result.run_dir)
    returning = min(t["time_s"] for t in samples if t["mode"] == "rtl")
    assert 0 <= returning - failsafe["sim_t"] < 20.0  # the vehicle was returning within 20 s
    assert not [r for r in flown if r["name"] == "flight.fly_to" and r["sim_t"] > failsafe["sim_t"]]
    assert result.summary.outcome == "returned"
    last = samples[-1]
    assert last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3.0
