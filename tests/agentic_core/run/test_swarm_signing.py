"""``agentic-uav swarm run --connect URL,URL --signing-key FILE``: vehicles that require MAVLink 2 signing
(``agentic-uav sim --signing-key K --require-signing``) fly the swarm with the key, one key for every link; without
it, or with another key, the run stops before anything flies (exit 1, one line naming the vehicle and why), the
vehicles stay on the ground, and nothing waits; ``--signing-key`` without ``--connect`` and a bad key file are
usage errors (exit 2, naming the file). With a key the probe believes only frames signed with it."""

from __future__ import annotations

import asyncio
import json
import select
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from agentic_core.cli import main
from agentic_core.contracts.geodesy import offset_position
from agentic_core.run.swarm_connect import SigningMismatch, _Probe, find_fleet
from flight.signing import Signer, new_key, write_key_file
from flight.sim.environment import DEFAULT_HOME_ALT_MSL_M
from flight.vehicle import VehicleClient
from tests.flight.test_cli import free_udp_port, mute_udp_port
from tests.flight.test_cli_vehicle import listening_port, start_sim, stop

from .swarm_missions import ORIGIN, survey_mission


@pytest.fixture
def mission(tmp_path: Path) -> Path:
    return survey_mission(
        tmp_path / "signed.yaml", plan_id="signed",
        goal="Two signed vehicles survey a tiny area together.",
        box_m=(5, 15, -6, 6), layers_m=(6, 16), layer_m=6, max_iterations=20, hover_s=1,
    )  # fmt: skip


def _key(path: Path) -> Path:
    write_key_file(path, new_key())
    return path


@pytest.fixture
def key(tmp_path: Path) -> Path:
    return _key(tmp_path / "fleet.key")


class Fleet:
    """``agentic-uav sim`` processes, each requiring signing with one key; their URLs; stopped at the end."""

    def __init__(self) -> None:
        self.procs: list[subprocess.Popen[str]] = []
        self.ports: list[int] = []

    def start(self, sysid: int, east_m: float, *sign: str) -> str:
        lat, lon = offset_position(ORIGIN.lat_deg, ORIGIN.lon_deg, 0.0, east_m)
        port = free_udp_port()
        proc = start_sim("--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none", "--speed", "4",
                         "--sysid", str(sysid), "--home", f"{lat:.7f},{lon:.7f},{DEFAULT_HOME_ALT_MSL_M}",
                         *sign)  # fmt: skip
        self.procs.append(proc)
        assert listening_port(proc) == port
        self.ports.append(port)
        return f"udp://127.0.0.1:{port}"

    def signed_pair(self, key: Path) -> str:
        """Two vehicles that sign with ``key`` and refuse unsigned commands: ``--connect``'s argument."""
        sign = ("--signing-key", str(key), "--require-signing")
        return f"{self.start(4, -10.0, *sign)},{self.start(2, 10.0, *sign)}"

    def on_the_ground(self, key: Path) -> list[bool]:
        """For each vehicle, asked over a link signed with ``key``: disarmed, and at most 0.5 m up."""

        async def ask(port: int) -> bool:
            async with await VehicleClient.connect(("127.0.0.1", port), timeout_s=10.0,
                                                   signing_key=bytes.fromhex(key.read_text())) as client:  # fmt: skip
                sample = client.telemetry.sample()
                deadline = time.monotonic() + 10.0
                while (sample is None or sample.alt_m is None) and time.monotonic() < deadline:
                    await asyncio.sleep(0.05)
                    sample = client.telemetry.sample()
                assert sample is not None
                return not sample.armed and abs(sample.alt_m) <= 0.5

        return [asyncio.run(ask(port)) for port in self.ports]


@pytest.fixture
def fleet() -> Iterator[Fleet]:
    started = Fleet()
    yield started
    for proc in started.procs:
        code, _out, err = stop(proc)
        assert code == 0, err


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_signed_vehicles_fly_the_swarm_with_the_key(mission: Path, key: Path, tmp_path: Path, fleet: Fleet) -> None:
    urls = fleet.signed_pair(key)
    runs = tmp_path / "runs"
    began = time.monotonic()
    code = main(["swarm", "run", str(mission), "--connect", urls, "--signing-key", str(key), "--runs-dir", str(runs),
                 "--camera-hz", "2", "--max-wall-s", "90"])  # fmt: skip
    took = time.monotonic() - began
    (swarm_dir,) = runs.iterdir()
    summary = json.loads((swarm_dir / "summary.json").read_text(encoding="utf-8"))
    assert code == 0 and summary["outcome"] == "completed", (summary["problems"], took)
    assert {u: v["system_id"] for u, v in summary["uavs"].items()} == {"uav-2": 2, "uav-4": 4}
    for uav in ("uav-2", "uav-4"):
        run_dir = Path(summary["uavs"][uav]["run_dir"])
        trace = [json.loads(line) for line in (run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()]
        took_off = [r for r in trace if r.get("kind") == "tool" and r.get("name") == "flight.takeoff"]
        assert any(r.get("status") == "ok" for r in took_off), took_off
        assert summary["uavs"][uav]["outcome"] in ("completed", "returned")
        # each UAV's client signed with the key, as a single run's does (and keeps it, 0600, as a single run does)
        assert bytes.fromhex((run_dir / "signing.key").read_text()) == bytes.fromhex(key.read_text())
        assert (run_dir / "signing.key").stat().st_mode & 0o777 == 0o600
    outs = [stop(proc) for proc in fleet.procs]
    fleet.procs.clear()
    for code, out, err in outs:
        assert code == 0, err
        assert "refused nothing" in out  # every message of the run (probe and clients) came signed with the key


@pytest.mark.timeout(90)
@pytest.mark.parametrize("given", ["none", "another key"])
def test_without_the_key_or_with_another_nothing_flies(
    given: str, mission: Path, key: Path, tmp_path: Path, fleet: Fleet, capsys: Any
) -> None:
    urls = fleet.signed_pair(key)
    runs = tmp_path / "runs"
    sign = [] if given == "none" else ["--signing-key", str(_key(tmp_path / "other.key"))]
    began = time.monotonic()
    code = main(["swarm", "run", str(mission), "--connect", urls, *sign, "--runs-dir", str(runs), "--camera-hz", "2"])
    took = time.monotonic() - began
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if "error:" in line]
    assert code == 1 and len(lines) == 1 and "Traceback" not in err, err
    first_url = urls.split(",")[0]
    why = "signs its link and refuses unsigned commands" if given == "none" else "signs with another key"
    assert f"--connect {first_url}: the vehicle (system id 4) {why}" in lines[0]
    assert took < 15.0 and not runs.exists()  # at once, and no swarm directory for a swarm that never was
    assert fleet.on_the_ground(key) == [True, True]


@pytest.mark.timeout(60)
def test_a_key_for_a_vehicle_that_does_not_sign_is_refused_at_once(key: Path, fleet: Fleet) -> None:
    url = fleet.start(3, 0.0)  # no key: its frames are unsigned, and the client would take none of them
    area = [(ORIGIN.lat_deg, ORIGIN.lon_deg)]
    with pytest.raises(SigningMismatch, match=r"system id 3\) does not sign its link"):
        find_fleet([url], ORIGIN, area, signing_key=bytes.fromhex(key.read_text()))
    (found,) = find_fleet([url], ORIGIN, area)  # and without the key it is found as before
    assert found.uav == "uav-3"


def test_usage_errors_name_the_option_or_the_file(mission: Path, key: Path, tmp_path: Path, capsys: Any) -> None:
    runs = tmp_path / "runs"
    base = ["swarm", "run", str(mission), "--runs-dir", str(runs)]
    assert main([*base, "--vehicles", "2", "--signing-key", str(key)]) == 2
    err = capsys.readouterr().err
    assert "--signing-key goes with --connect" in err and "Traceback" not in err
    bad = tmp_path / "bad.key"
    bad.write_text("not a key\n", encoding="utf-8")
    for path, says in ((bad, "not a signing key"), (tmp_path / "missing.key", "cannot read the signing key"),
                       (tmp_path, "not a regular file")):  # fmt: skip
        began = time.monotonic()
        # a port nobody is asked: the key is read before any vehicle is
        assert main([*base, "--connect", "udp://127.0.0.1:9", "--signing-key", str(path)]) == 2
        err = capsys.readouterr().err
        assert f"{path}: {says}" in err and "Traceback" not in err, err
        assert time.monotonic() - began < 5.0
    assert not runs.exists()


def test_with_a_key_the_probe_believes_only_frames_signed_with_it(key: Path) -> None:
    secret = bytes.fromhex(key.read_text())

    def frames(signing: bytes | None, *messages: Any) -> bytes:
        mav = mavlink2.MAVLink(None, srcSystem=7, srcComponent=1)
        if signing is not None:
            Signer(signing).attach(mav)
        return b"".join(bytes(m.pack(mav)) for m in messages)

    def home(lat: float) -> Any:
        return mavlink2.MAVLink_home_position_message(int(lat * 1e7), 0, 0, 0.0, 0.0, 0.0, [1.0, 0, 0, 0], 0, 0, 0)

    beat = mavlink2.MAVLink_heartbeat_message(2, 12, 0, 0, 4, 3)
    with mute_udp_port() as port:
        probe = _Probe(f"udp://127.0.0.1:{port}", secret)
        try:
            probe.ask()  # binds its socket
            with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as vehicle:

                def hear(data: bytes) -> None:
                    vehicle.sendto(data, probe.sock.getsockname())
                    readable, _, _ = select.select([probe.sock], [], [], 5.0)
                    assert readable
                    probe.read()

                hear(frames(secret, beat))
                hear(frames(None, home(10.0)))  # a spoofer's home, unsigned
                hear(frames(new_key(), home(20.0)))  # and one signed with another key
                assert (probe.system_id, probe.home) == (7, None)  # as a tuple: mypy must not think home stays None
                assert probe.signed == {"ours", "unsigned", "other"} and probe.mismatch() is None
                hear(frames(secret, home(21.5)))
                hear(frames(None, home(10.0)))
                assert probe.home is not None and probe.home[0] == pytest.approx(21.5)
        finally:
            probe.sock.close()
