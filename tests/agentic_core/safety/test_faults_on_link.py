"""A scheduled fault reaches a vehicle in another process over MAVLink alone (``--connect``): the battery trap
flown on ``agentic-uav sim``, the drop to 18 % delivered as MAV_CMD_INJECT_FAILURE, the agent's failsafe acting on
the telemetry the link brings back."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from agentic_core.contracts.faults import parse_fault
from flight.signing import new_key, write_key_file
from tests.flight.test_cli import free_udp_port
from tests.flight.test_cli_vehicle import listening_port, stop

from .conftest import EXAMPLES, REPO, assert_safe_and_home, fly, judge, of_kind, records


def test_the_battery_trap_on_a_vehicle_in_another_process(tmp_path: Path) -> None:
    port = free_udp_port()
    key = tmp_path / "vehicle.key"  # a fault is a safety parameter and a command: in the air, only a signed link's
    write_key_file(key, new_key())
    vehicle = subprocess.Popen(
        [sys.executable, "-m", "flight.cli", "--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none",
         "--speed", "8", "--signing-key", str(key)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
    )  # fmt: skip
    mission = EXAMPLES / "battery_survey.yaml"
    try:
        assert listening_port(vehicle) == port
        result = fly(mission, tmp_path, connect=f"udp://127.0.0.1:{port}", signing_key=key,
                     faults=[parse_fault("battery=18%@S1")])  # fmt: skip
    finally:
        code, _, err = stop(vehicle)
    assert code == 0, err
    trace = records(result.run_dir, "trace.jsonl")
    (fault,) = of_kind(trace, "fault")
    assert fault["status"] == "ok"
    (failsafe,) = [r for r in of_kind(trace, "failsafe") if r["by"] == "agent"]
    assert failsafe["failsafe"] == "battery" and failsafe["battery_pct"] <= 18
    assert result.summary.outcome == "returned"
    judged = judge(result.run_dir, mission)
    returning = min(s["time_s"] for s in judged.samples if s["mode"] == "rtl")
    assert 0 <= returning - fault["sim_t"] < 20.0
    assert_safe_and_home(judged)
