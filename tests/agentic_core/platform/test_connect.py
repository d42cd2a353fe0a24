"""The same emergency mission flown on a vehicle in another process: ``agentic-uav sim`` started by the test,
reached only over MAVLink (``--connect udp://HOST:PORT``); perception takes the camera's pose from the link's
telemetry. The link is signed: the vehicle is started with ``--signing-key`` and the run with the same key."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.run.runner import RunSettings, run_mission
from flight.signing import new_key, write_key_file
from tests.flight.test_cli import free_udp_port, mute_udp_port
from tests.flight.test_cli_vehicle import listening_port, stop
from tests.tlogs import read_tlog

from .conftest import EMERGENCY, NEAR, PARAMS, REPO, assert_served, of_kind, trace


def start_vehicle(port: int, speed: str, key: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "flight.cli", "--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none",
         "--scene", str(NEAR), "--speed", speed, "--signing-key", str(key)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=REPO,
    )  # fmt: skip


@pytest.mark.slow
def test_the_emergency_mission_flies_on_a_vehicle_in_another_process(tmp_path: Path, smtp: Any) -> None:
    port = free_udp_port()
    key = tmp_path / "key.hex"
    write_key_file(key, new_key())
    vehicle = start_vehicle(port, "4", key)
    try:
        assert listening_port(vehicle) == port
        result = run_mission(
            RunSettings(
                mission=EMERGENCY, scene=NEAR, runs_dir=tmp_path / "runs", params=PARAMS, camera_hz=5.0,
                connect=f"udp://127.0.0.1:{port}", signing_key=key,
            ),
            progress=None,
        )  # fmt: skip
    finally:
        code, out, err = stop(vehicle)
    assert code == 0, err
    assert "refused nothing" in out  # every message of the run's client came signed with the key
    assert result.summary.outcome == "completed", result.summary
    records = assert_served(result.run_dir, smtp)
    (start,) = [r for r in of_kind(records, "run") if r.get("event") == "start"]
    assert start["backend"] == "link"
    assert result.summary.frames > 0 and not (result.run_dir / "snapshot.json").read_text().count('"vehicle":{')
    telemetry = (result.run_dir / "telemetry.jsonl").read_text(encoding="utf-8").splitlines()
    assert len(telemetry) >= 5 * result.summary.sim_duration_s * 0.9  # at least 5 Hz of the vehicle's clock
    # the flight log is the link as the agent's client saw it: the vehicle's messages and the client's own
    logged = read_tlog(result.run_dir / "flight.tlog")
    assert {m.get_srcSystem() for m in logged} == {1, 255}
    assert sum(m.get_type() == "GLOBAL_POSITION_INT" for m in logged) >= 50
    stamps = [m._timestamp for m in logged]
    assert stamps == sorted(stamps)


def test_a_vehicle_that_does_not_answer_stops_the_run_before_take_off(tmp_path: Path, capsys: Any) -> None:
    with mute_udp_port() as port:  # nobody answers there
        code = main(["run", str(EMERGENCY), "--scene", str(NEAR), "--runs-dir", str(tmp_path), "--quiet",
                     "--connect", f"udp://127.0.0.1:{port}"])  # fmt: skip
    err = capsys.readouterr().err
    assert code == 1 and "cannot reach the vehicle" in err and "Traceback" not in err
    records = trace(next(tmp_path.iterdir()))
    assert not [r for r in of_kind(records, "tool") if r.get("name") == "flight.takeoff"]


def test_a_bad_link_address_is_input_error(tmp_path: Path, capsys: Any) -> None:
    code = main(["run", str(EMERGENCY), "--runs-dir", str(tmp_path), "--quiet", "--connect", "tcp://somewhere"])
    assert code == 2 and "udp://HOST:PORT" in capsys.readouterr().err


def test_a_bad_signing_key_file_is_input_error(tmp_path: Path, capsys: Any) -> None:
    (tmp_path / "key").write_text("not a key")
    base = ["run", str(EMERGENCY), "--runs-dir", str(tmp_path / "runs"), "--quiet"]
    code = main([*base, "--connect", "udp://127.0.0.1:9", "--signing-key", str(tmp_path / "key")])
    err = capsys.readouterr().err
    assert code == 2 and str(tmp_path / "key") in err and "Traceback" not in err
    assert main([*base, "--signing-key", str(tmp_path / "key")]) == 2  # the simulator makes its own
    assert "goes with --connect" in capsys.readouterr().err
