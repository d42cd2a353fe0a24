"""``agentic-uav sim`` (flight.cli): argument parsing, and the vehicle as a subprocess stopped by SIGTERM."""

import argparse
import asyncio
import contextlib
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time

import pytest

from flight.cli import build_parser, parse_address, parse_home, parse_speed
from flight.signing import new_key, write_key_file
from flight.vehicle import VehicleClient
from tests.waiting import CONNECT_S


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def mute_udp_port():
    """A port on 127.0.0.1 where nobody answers, held for the ``with`` block by a socket that never reads: a port
    merely found free may be taken meanwhile by another test's vehicle, which would then hear what is sent there."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        yield s.getsockname()[1]


def test_arguments_parse():
    assert parse_speed("1") == 1.0 and parse_speed("4") == 4.0 and parse_speed("max") is None
    for bad in ("0", "-2", "fast-ish", "inf"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_speed(bad)
    assert parse_address("10.0.0.2:14550") == ("10.0.0.2", 14550) and parse_address("none") is None
    with pytest.raises(argparse.ArgumentTypeError):
        parse_address("14550")
    assert parse_home("21.42,39.89,310") == (21.42, 39.89, 310.0)
    args = build_parser().parse_args([])
    assert args.speed == 1.0 and args.gcs == ("127.0.0.1", 14550) and args.api == ("127.0.0.1", 14540)
    assert args.bind == ("127.0.0.1", 18570) and args.home is None
    args = build_parser().parse_args(["--speed", "max", "--api", "none", "--param", "GF_MAX_HOR_DIST=200"])
    assert args.speed is None and args.api is None and args.param == [("GF_MAX_HOR_DIST", 200.0)]


def read_line(stream, timeout_s):
    """The next line of ``stream``, or None after ``timeout_s`` (a reader thread: a pipe read cannot time out)."""
    box = []
    reader = threading.Thread(target=lambda: box.append(stream.readline()), daemon=True)
    reader.start()
    reader.join(timeout_s)
    return box[0] if box else None


def test_sim_runs_until_sigterm_and_stops_cleanly():
    gcs = free_udp_port()
    argv = ["--speed", "max", "--bind", "127.0.0.1:0", "--gcs", f"127.0.0.1:{gcs}", "--api", "none"]
    argv += ["--home", "21.42,39.89,310", "--param", "MIS_TAKEOFF_ALT=3", "--param", "SYS_FAILURE_EN=1"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "flight.cli", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        line = read_line(proc.stdout, 20.0)
        assert line is not None, "no banner"
        found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        assert found, line
        assert f"gcs 127.0.0.1:{gcs}" in line and "speed max" in line

        async def talk():
            async with await VehicleClient.connect(("127.0.0.1", int(found.group(1))), timeout_s=CONNECT_S) as client:
                telemetry = await client.wait_telemetry(5.0)
                assert telemetry is not None
                assert await client.get_param("SYS_FAILURE_EN") == 1  # failure injection enabled from the command line
                return telemetry

        telemetry = asyncio.run(talk())
        assert abs(telemetry.lat_deg - 21.42) < 1e-3 and abs(telemetry.alt_msl_m - 310.0) < 1.0

        started = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10.0)
        assert proc.returncode == 0, err
        assert time.monotonic() - started < 3.0
        assert "stopped" in out and "Traceback" not in err
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()


def test_sim_reports_a_port_in_use():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as taken:
        taken.bind(("127.0.0.1", 0))
        port = taken.getsockname()[1]
        done = subprocess.run(
            [sys.executable, "-m", "flight.cli", "--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none"],
            capture_output=True,
            text=True,
            timeout=30,
        )
    assert done.returncode == 1 and "error" in done.stderr and "Traceback" not in done.stderr


def test_sim_with_a_signing_key_answers_only_signed_clients_and_says_what_it_refused(tmp_path):
    key = new_key()
    write_key_file(tmp_path / "key.hex", key)
    argv = ["--speed", "max", "--bind", "127.0.0.1:0", "--gcs", "none", "--api", "none"]
    argv += ["--signing-key", str(tmp_path / "key.hex")]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "flight.cli", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        line = read_line(proc.stdout, 20.0)
        assert line is not None and "signing on" in line, line
        found = re.search(r"listening on 127\.0\.0\.1:(\d+)", line)
        assert found, line
        address = ("127.0.0.1", int(found.group(1)))

        async def talk():
            async with await VehicleClient.connect(address, timeout_s=CONNECT_S, signing_key=key) as client:
                assert await client.get_param("MIS_TAKEOFF_ALT") == 2.5
            async with await VehicleClient.connect(
                address, timeout_s=CONNECT_S
            ) as unsigned:  # it hears; it is not heard
                assert await unsigned.get_param("MIS_TAKEOFF_ALT", timeout_s=1.0) is None

        asyncio.run(talk())
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10.0)
        assert proc.returncode == 0 and "Traceback" not in err, err
        assert re.search(r"stopped; refused \{.*'unsigned': [1-9]", out), out
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.communicate()
