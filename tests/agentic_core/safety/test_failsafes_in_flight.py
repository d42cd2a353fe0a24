"""Failsafes on telemetry in whole runs: a scene's scheduled GPS loss lands the aircraft (the agent's failsafe and
the vehicle's own, both in the trace and the report), and a mission's flight-time limit brings it home."""

from __future__ import annotations

import math
import threading
import time
from pathlib import Path

from agentic_core.agent.pacing import Pace
from agentic_core.contracts.faults import parse_fault
from agentic_core.contracts.telemetry import TelemetrySample
from agentic_core.run.backends import SimBackend
from agentic_core.run.runner import MissionRun, RunSettings
from flight.sim.environment import WindSettings

from .conftest import BREACH_M, EXAMPLES, assert_safe_and_home, fly, judge, of_kind, records

SCENES = Path(__file__).parent / "scenes"


def test_a_gps_loss_from_the_scene_lands_and_both_failsafes_are_reported(tmp_path: Path) -> None:
    mission = EXAMPLES / "square_15m.yaml"
    result = fly(mission, tmp_path, scene=SCENES / "gps_trap.yaml", camera_hz=5.0)
    trace = records(result.run_dir, "trace.jsonl")
    (fault,) = of_kind(trace, "fault")
    assert fault["fault"] == "gps_loss@c1" and fault["status"] == "ok"
    agent = [r for r in of_kind(trace, "failsafe") if r["by"] == "agent"]
    vehicle = [r for r in of_kind(trace, "failsafe") if r["by"] == "vehicle"]
    assert [(r["failsafe"], r["action"]) for r in agent] == [("gps", "land")]
    assert any("GPS lost" in r["text"] for r in vehicle), vehicle
    assert result.summary.outcome == "landed"
    judged = judge(result.run_dir, mission)
    assert judged.ended_on_ground and judged.outside_m <= BREACH_M and judged.over_ceiling_m <= BREACH_M
    assert judged.ended_from_home_m > 10.0  # it came down where it lost its position, near the first corner
    report = result.report.read_text(encoding="utf-8")
    assert "the vehicle: GPS lost" in report and "the agent (gps): GPS lost its fix" in report


def test_the_mission_flight_time_limit_brings_the_aircraft_home(tmp_path: Path) -> None:
    text = (EXAMPLES / "square_15m.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "timed.yaml"
    mission.write_text(text.replace("  max_altitude_m: 20\n", "  max_altitude_m: 20\n  max_flight_time_s: 12\n"))
    result = fly(mission, tmp_path)
    trace = records(result.run_dir, "trace.jsonl")
    (failsafe,) = of_kind(trace, "failsafe")
    assert failsafe["failsafe"] == "flight_time" and failsafe["action"] == "rtl"
    judged = judge(result.run_dir, mission)
    airborne = min(s["time_s"] for s in judged.samples if s["armed"] and s["landed_state"] != "on_ground")
    assert 11.8 < failsafe["sim_t"] - airborne < 13.0  # telemetry.jsonl has a sample every 0.1 s
    assert result.summary.outcome == "returned"
    assert_safe_and_home(judged)


def test_a_lost_link_fires_the_agent_link_failsafe_and_the_vehicle_comes_home_on_its_own(tmp_path: Path) -> None:
    """The MAVLink signal cut mid-mission: the agent hears nothing for ``link_loss_s`` (seconds of the simulation)
    and ends the mission by its link failsafe; the vehicle, hearing nobody, returns by its own (``NAV_DLL_ACT``)."""
    text = (EXAMPLES / "square_15m.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "link.yaml"
    mission.write_text(text.replace("  max_altitude_m: 20\n", "  max_altitude_m: 20\n  link_loss_s: 2\n"))
    # The vehicle judges its data link on the wall clock while the simulation runs free. At full speed it could
    # hover away its battery in the seconds it waits (its battery failsafe then acts first), and the run ends a few
    # wall seconds after the cut (its own failsafe, RTL retries): so 40x real time, and the vehicle's data-link
    # timeout at its minimum, 5 s, as PX4 allows.
    settings = RunSettings(
        mission=mission, runs_dir=tmp_path / "runs", faults=[parse_fault("link_loss@c1")], speed=40.0
    )
    run = MissionRun(settings, progress=None)
    assert isinstance(run.backend, SimBackend) and run.backend.vehicle.params.set("COM_DL_LOSS_T", 5)
    result = run.execute()
    trace = records(result.run_dir, "trace.jsonl")
    (fault,) = of_kind(trace, "fault")
    assert fault["status"] == "ok"
    (failsafe,) = of_kind(trace, "failsafe")
    assert failsafe["failsafe"] == "link" and failsafe["by"] == "agent" and failsafe["silent_s"] >= 2.0
    assert run.control.stop_requested() == "rtl" and run.control.stopped_by == "failsafe"
    assert isinstance(run.backend, SimBackend) and "data_link" in run.backend.vehicle.failsafes.triggered
    truth = run.backend.sim.state()
    assert truth.landed and math.hypot(truth.north_m, truth.east_m) < 3.0


def test_wind_above_the_mission_limit_brings_the_aircraft_home(tmp_path: Path) -> None:
    """The vehicle's wind estimate (the simulator's steady wind, as its WIND_COV reports it) over
    ``max_wind_mps``: the agent's wind failsafe, once airborne, with the mission's action."""
    text = (EXAMPLES / "square_15m.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "windy.yaml"
    mission.write_text(text.replace("  max_altitude_m: 20\n", "  max_altitude_m: 20\n  max_wind_mps: 5\n"))
    run = MissionRun(RunSettings(mission=mission, runs_dir=tmp_path / "runs"), progress=None)
    assert isinstance(run.backend, SimBackend)
    run.backend.sim.set_wind(WindSettings.from_direction(6.0, from_deg=270.0))
    result = run.execute()
    trace = records(result.run_dir, "trace.jsonl")
    (failsafe,) = of_kind(trace, "failsafe")
    assert failsafe["failsafe"] == "wind" and failsafe["wind_mps"] == 6.0 and failsafe["action"] == "rtl"
    assert result.summary.outcome == "returned"
    assert_safe_and_home(judge(result.run_dir, mission))


def test_a_starved_process_is_not_a_lost_link(tmp_path: Path) -> None:
    """In lockstep a process short of CPU runs the simulation slowly, it does not silence it: the vehicle thread held
    up for three wall seconds in the air (thrice the mission's ``link_loss_s``) fires no link failsafe."""
    text = (EXAMPLES / "square_15m.yaml").read_text(encoding="utf-8")
    mission = tmp_path / "starved.yaml"
    mission.write_text(text.replace("  max_altitude_m: 20\n", "  max_altitude_m: 20\n  link_loss_s: 1\n"))
    run = MissionRun(RunSettings(mission=mission, runs_dir=tmp_path / "runs", camera_hz=5.0), progress=None)
    held = threading.Event()

    def starve(sample: TelemetrySample) -> None:
        if sample.alt_m > 8.0 and not held.is_set():
            held.set()
            time.sleep(3.0)  # the fault under test: the vehicle thread gets no CPU for 3 s

    run.backend.on_sample(starve)
    result = run.execute()
    assert held.is_set()
    trace = records(result.run_dir, "trace.jsonl")
    assert of_kind(trace, "failsafe") == []
    assert result.summary.outcome == "completed"


def test_the_link_clock_is_the_simulation_s_and_the_wall_s_once_the_vehicle_is_gone() -> None:
    backend = SimBackend(home=None, seed=0, pace=Pace(None))
    try:
        assert backend.link_clock() == backend.sim.time_s == 0.0
        backend.vehicle.run_for(1.0)
        assert backend.link_clock() == backend.sim.time_s == 1.0
    finally:
        backend.close()
    start = backend.link_clock()
    later = threading.Event()
    later.wait(0.05)
    assert start >= 1.0 and backend.link_clock() > start  # a killed UAV's silence still grows
