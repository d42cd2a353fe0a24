"""A stop or a pause is heard during a landing and a return, end to end: an RTL, or Ctrl-C (an abort, ``on_abort:
rtl``), during the emergency mission's approved landing beside the casualty holds the descent and brings the
aircraft home, no kit released; a pause during the mission's return holds the aircraft where it is, and resume flies
the return again. Before, both flew on to the ground: the stop found the aircraft landed beside the casualty, 147 m
from home ("nothing to do"), and the pause was heard only once the return had landed."""

from __future__ import annotations

import math
import os
import signal
import threading
from pathlib import Path
from typing import Any

import pytest

from agentic_core.run.cli import _signals_stop
from agentic_core.run.runner import MissionRun, RunResult, RunSettings
from tests.waiting import wait_for

from .conftest import EMERGENCY, NEAR, PARAMS, fly_steered, of_kind, pause_and_hold, telemetry, tools_ok, trace

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]


def descending_beside_the_casualty(run: MissionRun) -> bool:
    """The approved landing is under way and well below the approach's 15 m (its descent, not the flight there)."""
    sample = run.last_sample
    return sample is not None and sample.mode == "land" and sample.landed_state == "landing" and sample.alt_m < 10.0


def emergency(tmp_path: Path) -> MissionRun:
    settings = RunSettings(mission=EMERGENCY, scene=NEAR, runs_dir=tmp_path / "runs", params=PARAMS, camera_hz=2.0)
    return MissionRun(settings, progress=None)


def came_home_from_the_landing(result: RunResult, asked_alt: float) -> list[dict[str, Any]]:
    """The landing was held (interrupted, the hold acknowledged), no kit released, and the aircraft climbed back
    and landed at home."""
    records = trace(result.run_dir)
    landings = [r for r in of_kind(records, "tool") if r.get("name") == "flight.land"]
    assert [r["status"] for r in landings] == ["interrupted"] and landings[0]["hold"] == "ok", landings
    assert not tools_ok(records, "flight.deploy_payload")
    assert tools_ok(records, "flight.rtl")
    flown = telemetry(result.run_dir)
    after = [t for t in flown if t["time_s"] > landings[0]["sim_t"]]
    away = [t for t in after if math.hypot(t["north_m"], t["east_m"]) > 10.0]
    assert away and min(t["alt_m"] for t in away) > 1.0  # never touched down beside them
    assert max(t["alt_m"] for t in after) > asked_alt + 5.0  # the return climbed back
    last = flown[-1]
    assert last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3.0, last
    end = next(r for r in of_kind(records, "run") if r.get("event") == "end")
    assert end["ended"].startswith("on the ground") and "from home" in end["ended"]
    return records


def test_an_rtl_during_the_approved_landing_holds_it_and_brings_the_aircraft_home(tmp_path: Path, smtp: Any) -> None:
    run = emergency(tmp_path)
    asked: list[float] = []

    def operator() -> None:
        wait_for(lambda: descending_beside_the_casualty(run), timeout_s=240.0, what="the approved landing's descent")
        asked.append(run.last_sample.alt_m if run.last_sample is not None else math.nan)
        run.control.rtl(by="tester")

    result = fly_steered(run, operator)
    assert asked, "the landing never began"
    assert result.summary.outcome == "returned"
    came_home_from_the_landing(result, asked[0])


def test_ctrl_c_during_the_approved_landing_does_what_on_abort_says_and_comes_home(tmp_path: Path, smtp: Any) -> None:
    """SIGINT through the run's own handler (the CLI's): an abort by ``signal``, and the mission's ``on_abort`` is
    the default, ``rtl``."""
    run = emergency(tmp_path)
    asked: list[float] = []

    def operator() -> None:
        wait_for(lambda: descending_beside_the_casualty(run), timeout_s=240.0, what="the approved landing's descent")
        asked.append(run.last_sample.alt_m if run.last_sample is not None else math.nan)
        os.kill(os.getpid(), signal.SIGINT)

    steer = threading.Thread(target=operator, daemon=True)
    steer.start()
    with _signals_stop(run):  # the handler runs in this (the main) thread, as in `agentic-uav run`
        result = run.execute()
    steer.join(10.0)
    assert asked, "the landing never began"
    assert result.summary.outcome == "interrupted"
    records = came_home_from_the_landing(result, asked[0])
    (command,) = of_kind(records, "control")
    assert command["command"] == "abort" and command["by"] == "signal"


HOME_RUN = """
plan_id: out-and-home
goal: Fly one waypoint, then return home and land.
limits:
  geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 150}
  max_altitude_m: 40
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: out, action: fly_to, depends_on: [up], args: {north_m: 60, east_m: 0, alt_m: 10}}
  - {id: home, action: rtl, depends_on: [out]}
"""


def test_a_pause_during_the_return_holds_the_aircraft_and_resume_flies_the_return_again(tmp_path: Path) -> None:
    mission = tmp_path / "home_run.yaml"
    mission.write_text(HOME_RUN, encoding="utf-8")
    run = MissionRun(RunSettings(mission=mission, runs_dir=tmp_path / "runs", camera_hz=2.0), progress=None)
    held: list[tuple[float, float]] = []

    def returning() -> bool:
        sample = run.last_sample
        return sample is not None and sample.mode == "rtl" and 20.0 < sample.north_m < 45.0 and sample.alt_m > 5.0

    result = fly_steered(run, pause_and_hold(run, returning, "the return flying home", 6.0, held))
    assert held, "the operator thread never resumed"
    assert result.summary.outcome == "completed"
    start, end = held[0]
    flown = telemetry(result.run_dir)
    during = [t for t in flown if start <= t["time_s"] <= end]
    assert during and all(t["alt_m"] > 5.0 for t in during)  # held in the air, not landed
    assert max(t["north_m"] for t in during) - min(t["north_m"] for t in during) < 1.0
    assert max(math.hypot(t["vn_mps"], t["ve_mps"]) for t in during) < 0.5
    returns = [r for r in of_kind(trace(result.run_dir), "tool") if r.get("name") == "flight.rtl"]
    assert [r["status"] for r in returns] == ["interrupted", "ok"], returns
    last = flown[-1]
    assert last["alt_m"] < 0.5 and math.hypot(last["north_m"], last["east_m"]) < 3.0, last
