"""The ground-station stream and the flight log of ``agentic-uav run``: a pymavlink ground station on the ``--gcs``
port follows the mission and commands the vehicle; the run's ``flight.tlog`` opens with pymavlink's log reader;
the report shows the flight over time. The stream and the log are read on one run, flown once for both tests."""

from __future__ import annotations

import threading
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError
from pymavlink import mavutil

from agentic_core.cli import main
from agentic_core.run.runner import RunSettings
from agentic_core.run.settings import GCS_ENV
from flight.signing import read_key_file
from tests.flight.test_cli import free_udp_port
from tests.shared_flights import Flown, shared_flights
from tests.tlogs import read_tlog

from ..platform.conftest import EMERGENCY, NEAR, PARAMS, of_kind, trace

MAV = mavutil.mavlink


@dataclass
class Watched:
    """One run of ``agentic-uav run`` with a pymavlink ground station on its ``--gcs`` port, and what that station
    saw and was answered."""

    code: int
    run_dir: Path
    seen: Counter[str] = field(default_factory=Counter)
    vehicle_kinds: set[tuple[int, int]] = field(default_factory=set)
    airborne: list[Any] = field(default_factory=list)
    answers: list[Any] = field(default_factory=list)
    errors: list[BaseException] = field(default_factory=list)


def fly_watched(folder: Path) -> Watched:
    """The emergency mission through the CLI (in this thread, where it can take Ctrl-C), with a ground station on
    another thread that, once the aircraft is up, asks for the autopilot's version as QGroundControl does on
    connecting: unsigned first, then signed with the run's key."""
    port = free_udp_port()
    runs = folder / "runs"
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, source_component=190)
    watched = Watched(code=-1, run_dir=runs)
    finished = threading.Event()

    def station() -> None:
        asked = False
        try:
            while not finished.is_set():
                msg = gcs.recv_match(blocking=True, timeout=0.2)
                if msg is None:
                    continue
                kind = msg.get_type()
                watched.seen[kind] += 1
                if kind == "HEARTBEAT" and msg.get_srcSystem() == 1:
                    watched.vehicle_kinds.add((msg.autopilot, msg.type))
                elif kind == "GLOBAL_POSITION_INT" and msg.relative_alt > 5_000:
                    watched.airborne.append(msg)
                elif kind in ("COMMAND_ACK", "AUTOPILOT_VERSION") and msg.get_srcSystem() == 1:
                    watched.answers.append(msg)
                if watched.airborne and not asked:  # in the air, mid-mission
                    # unsigned first: the run's vehicle takes commands only signed with the run's key
                    gcs.mav.command_long_send(1, 1, MAV.MAV_CMD_REQUEST_MESSAGE, 0,
                                              MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)  # fmt: skip
                    (key_file,) = runs.glob("*/signing.key")
                    gcs.setup_signing(read_key_file(key_file), sign_outgoing=True, link_id=2)
                    gcs.mav.heartbeat_send(MAV.MAV_TYPE_GCS, MAV.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                    gcs.mav.command_long_send(1, 1, MAV.MAV_CMD_REQUEST_MESSAGE, 0,
                                              MAV.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)  # fmt: skip
                    asked = True
        except BaseException as exc:  # reported by the tests, which read ``errors``
            watched.errors.append(exc)

    listening = threading.Thread(target=station, name="test-gcs", daemon=True)
    listening.start()
    try:
        watched.code = main(["run", str(EMERGENCY), "--scene", str(NEAR), "--runs-dir", str(runs), "--quiet",
                             "--camera-hz", "5", "--gcs", f"127.0.0.1:{port}",
                             *[f"--param={k}={v}" for k, v in PARAMS.items()]])  # fmt: skip
    finally:
        finished.set()
        listening.join(timeout=10.0)
        gcs.close()
    (watched.run_dir,) = runs.iterdir()
    return watched


@pytest.fixture(scope="module")
def watched_run(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Flown[Watched]]:
    """The one watched run both tests below read, with the SMTP server its alert went to."""
    with shared_flights(tmp_path_factory) as flights:
        yield flights.get("watched", fly_watched)


@pytest.mark.slow
def test_a_ground_station_on_the_gcs_port_follows_the_mission_and_commands_it_with_the_runs_key(
    watched_run: Flown[Watched],
) -> None:
    watched = watched_run.result
    assert not watched.errors, watched.errors
    assert watched.code == 0 and of_kind(trace(watched.run_dir), "run")[-1]["outcome"] == "completed"
    assert len(watched_run.smtp.inbox.envelopes) == 1  # the alert went out by SMTP: not degraded
    seen = watched.seen
    assert seen["HEARTBEAT"] >= 5 and seen["ATTITUDE"] and seen["SYS_STATUS"], seen
    assert watched.vehicle_kinds == {(MAV.MAV_AUTOPILOT_PX4, MAV.MAV_TYPE_QUADROTOR)}
    assert len(watched.airborne) >= 10, "no positions in the air reached the ground station"
    acks = [m for m in watched.answers if m.get_type() == "COMMAND_ACK"]
    # one answer: to the signed request; the unsigned one was refused without a word, as PX4 does
    assert [(m.command, m.result, m.target_system) for m in acks] == [(MAV.MAV_CMD_REQUEST_MESSAGE, 0, 255)]
    assert [m for m in watched.answers if m.get_type() == "AUTOPILOT_VERSION"], "the request was not answered"
    # the ground station's own messages are in the vehicle's flight log, between the vehicle's
    logged = read_tlog(watched.run_dir / "flight.tlog")
    assert [m for m in logged if m.get_type() == "COMMAND_LONG" and m.get_srcSystem() == 255
            and m.command == MAV.MAV_CMD_REQUEST_MESSAGE]  # fmt: skip


def test_every_run_writes_a_flight_log_that_pymavlink_replays(watched_run: Flown[Watched]) -> None:
    """Read on the watched run: a ground station's messages in the log must not break what is said of it."""
    assert watched_run.result.code == 0
    run_dir = watched_run.result.run_dir
    messages = read_tlog(run_dir / "flight.tlog")
    stamps = [m._timestamp for m in messages]
    assert stamps == sorted(stamps), "a stamp went back"
    beats = [m for m in messages if m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1]
    positions = [m for m in messages if m.get_type() == "GLOBAL_POSITION_INT"]
    assert len(beats) >= 10 and len(positions) >= 50
    # stamped on the simulated clock: the log spans the flight as the vehicle flew it, and its positions are the
    # ones telemetry.jsonl recorded
    span = stamps[-1] - stamps[0]
    sim_s = float(positions[-1].time_boot_ms - positions[0].time_boot_ms) / 1000.0
    assert abs(span - sim_s) < 2.0, (span, sim_s)
    assert max(p.relative_alt for p in positions) > 5_000
    # what the agent sent is there too: its take-off and its landing
    commands = {m.command for m in messages if m.get_type() in ("COMMAND_LONG", "COMMAND_INT")}
    assert MAV.MAV_CMD_NAV_TAKEOFF in commands, commands
    # and the report shows the flight over time beside the trajectory
    report = (run_dir / "report.md").read_text(encoding="utf-8")
    for picture in ("trajectory.png", "flight.png"):
        assert f"]({picture})" in report and (run_dir / picture).read_bytes()[:4] == b"\x89PNG"


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--gcs", "14550"], "--gcs: expected HOST:PORT or none"),
        (["--gcs", "127.0.0.1:70000"], "--gcs: expected HOST:PORT or none"),
        (["--gcs", "nosuch.invalid:14550"], "--gcs nosuch.invalid:14550: cannot find that host"),
        (["--gcs", "127.0.0.1:14550", "--connect", "udp://127.0.0.1:1"], "--gcs is for the simulated vehicle"),
    ],
    ids=["no-host", "bad-port", "unknown-host", "with-connect"],
)
def test_a_bad_ground_station_address_is_refused_before_anything_flies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], said: str
) -> None:
    code = main(["run", str(EMERGENCY), "--scene", str(NEAR), "--runs-dir", str(tmp_path), "--quiet", *args])
    err = capsys.readouterr().err
    assert code == 2 and said in err and "Traceback" not in err, err
    assert not list(tmp_path.iterdir()), "a run folder was made for a run that never started"


def test_the_ground_station_defaults_to_14550_or_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(GCS_ENV)
    assert RunSettings(mission=EMERGENCY).gcs_address == ("127.0.0.1", 14550)
    monkeypatch.setenv(GCS_ENV, "127.0.0.1:14551")
    assert RunSettings(mission=EMERGENCY).gcs_address == ("127.0.0.1", 14551)
    assert RunSettings(mission=EMERGENCY, gcs="off").gcs_address is None
    monkeypatch.setenv(GCS_ENV, "nonsense")
    with pytest.raises(ValidationError, match=GCS_ENV.replace("_", ".")):
        RunSettings(mission=EMERGENCY)
