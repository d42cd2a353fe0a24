"""``agentic-uav sim`` as a vehicle in another process: home from a scene, a client flies it, samples arrive,
SIGTERM ends it; bad homes, scenes and snapshots are named, and a snapshot resumes in the new process."""

import asyncio
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from agentic_core.contracts.telemetry import TelemetrySample
from flight.cli import parse_home
from flight.mavlink import MavlinkVehicle
from flight.sim import Environment, Home, Simulator
from flight.vehicle import CAMERA_STREAMS, VehicleClient

from .test_cli import free_udp_port, read_line
from .test_client import run

REPO = Path(__file__).resolve().parents[2]


def start_sim(*argv):
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "flight.cli", *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        cwd=REPO,
    )


def listening_port(proc):
    line = read_line(proc.stdout, 30.0)
    assert line is not None, "no banner"
    found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
    assert found, line
    return int(found.group(1))


def stop(proc):
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=10.0)
    return proc.returncode, out, err


def test_a_client_flies_the_vehicle_in_another_process_and_sigterm_ends_it():
    port = free_udp_port()
    proc = start_sim(
        "--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none", "--scene", "scenes/hajj_normal.yaml"
    )
    try:
        assert listening_port(proc) == port
        samples: list[tuple[float, TelemetrySample]] = []

        async def fly():
            async with await VehicleClient.connect(("127.0.0.1", port), timeout_s=10.0) as client:
                assert all((await client.set_stream_rates({name: 10.0 for name in CAMERA_STREAMS})).values())
                client.on_sample(lambda s: samples.append((time.monotonic(), s)))
                assert (await client.arm()).ok
                result = await client.takeoff(10.0)
                assert result.ok, result.reason
                first = len(samples)
                deadline = time.monotonic() + 5.0
                while len(samples) < first + 10 and time.monotonic() < deadline:
                    await asyncio.sleep(0.02)
                return first

        first = run(fly(), timeout_s=60.0)
        hovering = samples[first:]
        assert len(hovering) >= 10
        wall_span = hovering[-1][0] - hovering[0][0]
        assert (len(hovering) - 1) / wall_span >= 5.0  # at real time: >= 5 samples per wall second
        times = [s.time_s for _, s in samples]
        assert times == sorted(times)
        s = hovering[-1][1]
        assert abs(s.lat_deg - 21.4133) < 1e-4 and abs(s.lon_deg - 39.8933) < 1e-4  # the scene's home
        assert s.alt_msl_m is not None and abs(s.alt_msl_m - 310.0) < 0.8
        assert abs(s.alt_m - 10.0) < 0.8 and abs(s.down_m + 10.0) < 0.8
        assert s.armed and s.mode in ("hold", "takeoff") and s.landed_state in ("in_air", "takeoff")
        assert s.battery_pct is not None and 90.0 < s.battery_pct <= 100.0
        assert abs(s.roll_deg) < 10.0 and abs(s.pitch_deg) < 10.0
        started = time.monotonic()
        code, out, err = stop(proc)
        assert code == 0, err
        assert time.monotonic() - started < 5.0 and "stopped" in out and "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


def test_a_snapshot_resumes_in_another_process(tmp_path):
    vehicle = MavlinkVehicle(Simulator(Environment(home=Home(21.5, 39.7, 250.0)), seed=3), gcs=None, api=None)
    vehicle.navigator.arm()
    vehicle.navigator.takeoff(12.0)
    vehicle.run_for(12.0)
    assert vehicle.sim.release_payload()
    before = vehicle.sim.state()
    snapshot = tmp_path / "vehicle.json"
    snapshot.write_text(vehicle.snapshot().model_dump_json(), encoding="utf-8")
    vehicle.close()
    proc = start_sim("--bind", "127.0.0.1:0", "--gcs", "none", "--api", "none", "--resume", str(snapshot))
    try:
        port = listening_port(proc)

        async def look():
            async with await VehicleClient.connect(("127.0.0.1", port), timeout_s=10.0) as client:
                assert await client.wait_telemetry(5.0) is not None
                return client.telemetry

        t = run(look())
        assert t.armed and t.alt_m is not None and abs(t.alt_m - 12.0) < 0.8
        assert t.time_boot_s is not None and t.time_boot_s >= before.time_s  # the clock goes on
        assert t.battery_pct is not None and t.battery_pct <= round(before.battery_pct)
        assert t.home_lat_deg is None or abs(t.home_lat_deg - 21.5) < 1e-6
        assert t.lat_deg is not None and abs(t.lat_deg - 21.5) < 1e-4
        code, _, err = stop(proc)
        assert code == 0, err
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--home", "21.4"], "LAT,LON[,ALT]"),
        (["--home", "95,39,300"], "home position out of range"),
        (["--scene", "no/such/scene.yaml"], "no/such/scene.yaml"),
        (["--resume", "no/such/snapshot.json"], "no/such/snapshot.json"),
        (["--scene", "scenes/hajj_normal.yaml", "--home", "21,39"], "not allowed with"),
    ],
)
def test_bad_homes_scenes_and_snapshots_are_named_with_exit_status_2(argv, named):
    done = subprocess.run(
        [sys.executable, "-m", "flight.cli", "--bind", "127.0.0.1:0", "--gcs", "none", "--api", "none", *argv],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert done.returncode == 2 and named in done.stderr and "Traceback" not in done.stderr, done.stderr


def test_a_bad_snapshot_or_scene_file_is_named_by_file_and_field(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"version": 1, "sim": {"time_s": "soon"}}', encoding="utf-8")
    scene = tmp_path / "scene.yaml"
    scene.write_text("id: x\nhome: {lat_deg: 21.4, lon_deg: 39.9, alt_msl_m: nope}\n", encoding="utf-8")
    for argv, named in ((["--resume", str(bad)], f"{bad}: sim.time_s"), (["--scene", str(scene)], f"{scene}:2")):
        done = subprocess.run(
            [sys.executable, "-m", "flight.cli", "--bind", "127.0.0.1:0", "--gcs", "none", "--api", "none", *argv],
            capture_output=True,
            text=True,
            timeout=60,
            cwd=REPO,
        )
        assert done.returncode == 2 and named in done.stderr and "Traceback" not in done.stderr, done.stderr
    assert parse_home("1,2") == (1.0, 2.0, 300.0)
