"""With ``--connect`` the run's times count from the run's start on the vehicle's clock, not from the vehicle's
boot: a vehicle up 2,000 s flies a short mission whose trace, telemetry, summary and report all start near 0 and
end near the flight's length; resuming the finished run goes on from where it stood (where its files end, even
when its last checkpoint came earlier), never from the vehicle's uptime; and a vehicle clock that goes back (a
reboot) does not take the run's back."""

from __future__ import annotations

import json
import re
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts import TelemetrySample
from agentic_core.run.run_clock import RunClock, resumed_at
from agentic_core.run.runner import RunSettings, resume_run, run_mission
from agentic_core.run.state_files import SNAPSHOT_FILE
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from tests.flight.test_cli import free_udp_port
from tests.flight.test_cli_vehicle import listening_port, start_sim, stop

UPTIME_S = 2000.0
MISSION = """\
plan_id: uptime
goal: Take off to 4 m and land where it is.
steps:
  - {id: up, action: takeoff, args: {altitude_m: 4}}
  - {id: down, action: land, depends_on: [up]}
"""


@pytest.fixture
def old_vehicle(tmp_path: Path) -> Iterator[str]:
    """``agentic-uav sim`` whose clock starts at :data:`UPTIME_S` (a snapshot on the ground, its clock moved on),
    as a vehicle up half an hour before the run; its URL."""
    vehicle = MavlinkVehicle(Simulator(seed=1), gcs=None, api=None)
    data = vehicle.snapshot().model_dump(mode="json")
    vehicle.close()
    data["sim"]["time_s"] = UPTIME_S
    snapshot = tmp_path / "up-a-while.json"
    snapshot.write_text(json.dumps(data), encoding="utf-8")
    port = free_udp_port()
    proc: subprocess.Popen[str] = start_sim("--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none",
                                            "--speed", "4", "--resume", str(snapshot))  # fmt: skip
    try:
        assert listening_port(proc) == port
        yield f"udp://127.0.0.1:{port}"
    finally:
        code, _out, err = stop(proc)
        assert code == 0, err


def lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


def duration_in_report(run_dir: Path) -> float:
    found = re.search(r"Duration: ([\d.]+) s", (run_dir / "report.md").read_text(encoding="utf-8"))
    assert found is not None
    return float(found.group(1))


@pytest.mark.timeout(180)
def test_a_connected_runs_times_count_from_its_start_not_the_vehicles_boot(old_vehicle: str, tmp_path: Path) -> None:
    mission = tmp_path / "uptime.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    runs = tmp_path / "runs"
    result = run_mission(RunSettings(mission=mission, runs_dir=runs, connect=old_vehicle, camera_hz=2.0),
                         progress=None)  # fmt: skip
    assert result.summary.outcome == "completed", result.summary
    flown = result.summary.sim_duration_s
    assert 1.0 < flown < 120.0  # a take-off to 4 m and a landing, not the vehicle's 2,000 s of uptime
    trace = lines(result.run_dir / "trace.jsonl")
    times = [r["sim_t"] for r in trace if r.get("sim_t") is not None]
    assert times and min(times) >= 0.0 and max(times) <= flown + 1e-6
    (takeoff,) = [r for r in trace if r.get("name") == "flight.takeoff" and r.get("status") == "ok"]
    assert takeoff["sim_t"] < 60.0
    telemetry = [r["time_s"] for r in lines(result.run_dir / "telemetry.jsonl")]
    assert telemetry[0] < 5.0 and telemetry == sorted(telemetry) and telemetry[-1] <= flown + 1e-6
    assert duration_in_report(result.run_dir) == pytest.approx(flown, abs=0.05)

    snapshot = result.run_dir / SNAPSHOT_FILE  # its last checkpoint taken at take-off, seconds before the run ended
    snapshot.write_text(json.dumps({**json.loads(snapshot.read_text()), "sim_t": takeoff["sim_t"]}), encoding="utf-8")
    again = resume_run(runs, result.run_id, progress=None)  # the finished run, resumed: nothing left to fly
    assert again.summary.outcome == "completed"
    assert flown <= again.summary.sim_duration_s < flown + 60.0  # on from where it stood, not from the uptime
    assert duration_in_report(again.run_dir) == pytest.approx(again.summary.sim_duration_s, abs=0.05)
    resumed = [r["sim_t"] for r in lines(again.run_dir / "trace.jsonl")[len(trace) :] if r.get("sim_t") is not None]
    assert resumed and min(resumed) >= flown - 1e-6 and max(resumed) < flown + 60.0
    telemetry = [r["time_s"] for r in lines(again.run_dir / "telemetry.jsonl")]
    assert telemetry == sorted(telemetry)


def sample(t: float) -> TelemetrySample:
    return TelemetrySample(time_s=t, lat_deg=21.4, lon_deg=39.9, alt_m=0.0, north_m=0.0, east_m=0.0, down_m=0.0)


def test_a_vehicle_clock_that_goes_back_does_not_take_the_runs_back() -> None:
    clock = RunClock(start_s=50.0)  # a resumed run that stood at 50 s
    got = [clock(sample(t)).time_s for t in (900.0, 901.0, 903.5, 0.2, 1.2, 1.0, 2.0)]  # a reboot, then a stray
    assert got == sorted(got) and got[0] == 50.0
    assert got[:3] == [50.0, 51.0, 53.5] and got[3] == 53.5 and got[4] == pytest.approx(54.5)


def test_a_resumed_run_goes_on_from_its_last_telemetry_even_past_its_snapshot(tmp_path: Path) -> None:
    rows = [json.dumps(sample(t).model_dump(mode="json")) for t in (10.0, 11.0, 12.5)]
    (tmp_path / "telemetry.jsonl").write_text("\n".join(rows) + '\n{"time_s": 99', encoding="utf-8")  # cut short
    assert resumed_at(tmp_path, 11.0) == 12.5
    assert resumed_at(tmp_path, 20.0) == 20.0
    assert resumed_at(tmp_path / "nothing-here", None) == 0.0
    assert resumed_at(tmp_path / "nothing-here", float("nan")) == 0.0
