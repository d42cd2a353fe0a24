"""``agentic-uav swarm run --connect URL,URL``: vehicles in processes of their own (``agentic-uav sim``, each with its
system id and home) fly one swarm mission, named by system id and placed in the mission's frame through WGS-84;
a URL nobody answers, one vehicle named twice and a vehicle far from the area are refused at once, naming them.
``agentic-uav sim --vehicles N`` serves N in one process with PX4's numbering, each found as its own vehicle."""

from __future__ import annotations

import json
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import offset_position
from agentic_core.run import swarm_connect
from agentic_core.run.swarm_connect import find_fleet
from flight.cli import main as sim_main
from flight.sim.environment import DEFAULT_HOME_ALT_MSL_M
from tests.flight.test_cli import free_udp_port, mute_udp_port, read_line
from tests.flight.test_cli_vehicle import listening_port, start_sim, stop

from .swarm_missions import ORIGIN, survey_mission


@pytest.fixture
def mission(tmp_path: Path) -> Path:
    return survey_mission(
        tmp_path / "connect.yaml", plan_id="connect",
        goal="Two vehicles of their own survey a small area together.",
        box_m=(15, 45, -20, 20), layers_m=(15, 25), layer_m=20, max_iterations=50, hover_s=2,
    )  # fmt: skip


def _vehicle(sysid: int, east_m: float, speed: str = "1", north_m: float = 0.0) -> tuple[subprocess.Popen[str], str]:
    """``agentic-uav sim`` in a process of its own, ``east_m`` east of the origin; it and its URL."""
    lat, lon = offset_position(ORIGIN.lat_deg, ORIGIN.lon_deg, north_m, east_m)
    port = free_udp_port()
    proc = start_sim("--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none", "--speed", speed,
                     "--sysid", str(sysid), "--home", f"{lat:.7f},{lon:.7f},{DEFAULT_HOME_ALT_MSL_M}")  # fmt: skip
    assert listening_port(proc) == port
    return proc, f"udp://127.0.0.1:{port}"


@pytest.fixture
def vehicles() -> Iterator[list[subprocess.Popen[str]]]:
    started: list[subprocess.Popen[str]] = []
    yield started
    for proc in started:
        code, _, err = stop(proc)
        assert code == 0, err


def _lines(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines()]


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_vehicles_of_their_own_fly_the_swarm_named_by_system_id_in_the_missions_frame(
    mission: Path, tmp_path: Path, vehicles: list[subprocess.Popen[str]]
) -> None:
    west, west_url = _vehicle(5, -10.0, speed="4")
    east, east_url = _vehicle(3, 10.0, speed="4")
    vehicles += [west, east]
    runs = tmp_path / "runs"
    code = main(["swarm", "run", str(mission), "--connect", f"{west_url},{east_url}", "--runs-dir", str(runs)])
    (swarm_dir,) = runs.iterdir()
    summary = json.loads((swarm_dir / "summary.json").read_text(encoding="utf-8"))
    assert code == 0, summary["problems"]
    assert {u: v["system_id"] for u, v in summary["uavs"].items()} == {"uav-3": 3, "uav-5": 5}  # by system id
    assert all(summary["sectors"].values()) and summary["outcome"] == "completed"
    for uav, east_m in (("uav-3", 10.0), ("uav-5", -10.0)):
        first = _lines(Path(summary["uavs"][uav]["run_dir"]) / "telemetry.jsonl")[0]
        # each vehicle counts from its own home; the swarm places it from the mission's origin
        assert first["east_m"] == pytest.approx(east_m, abs=1.5) and first["north_m"] == pytest.approx(0.0, abs=1.5)
    separation = summary["separation"]
    assert separation["losses"] == 0 and separation["instants"] > 10
    # no closer than the mission's vertical separation (8 m): one above the other at worst (their layers are 10 m
    # apart), as the airspace reserved their legs
    assert separation["min_distance_m"] >= 8.0


def test_a_url_nobody_answers_is_a_clear_error_at_once(mission: Path, tmp_path: Path, capsys: Any) -> None:
    with mute_udp_port() as port:
        silent = f"udp://127.0.0.1:{port}"
        began = time.monotonic()
        code = main(["swarm", "run", str(mission), "--connect", silent, "--runs-dir", str(tmp_path / "runs")])
        took = time.monotonic() - began
    err = capsys.readouterr().err
    assert code == 1 and f"--connect {silent}: no vehicle answered" in err and "Traceback" not in err
    assert took < 10.0 and not (tmp_path / "runs").exists()  # no swarm directory for a swarm that never was


def test_one_vehicle_named_twice_and_one_far_away_are_refused(
    mission: Path, tmp_path: Path, capsys: Any, vehicles: list[subprocess.Popen[str]]
) -> None:
    near, url = _vehicle(2, 0.0)
    far, far_url = _vehicle(4, 0.0, north_m=30_000.0)
    vehicles += [near, far]
    base = ["swarm", "run", str(mission), "--runs-dir", str(tmp_path / "runs")]
    assert main([*base, "--connect", f"{url},{url.replace('127.0.0.1', 'localhost')}"]) == 2
    err = capsys.readouterr().err
    assert "the same vehicle (system id 2)" in err and url in err and "Traceback" not in err
    assert main([*base, "--connect", f"{url},{far_url}"]) == 2
    err = capsys.readouterr().err
    assert f"--connect {far_url}: the vehicle (system id 4) is 30.0 km from the mission's area" in err
    assert not (tmp_path / "runs").exists()


def _two_free_ports() -> int:
    """A port ``p`` with ``p + 1`` free too (PX4's numbering puts vehicle i on the first port + i)."""
    while True:
        port: int = free_udp_port()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(("127.0.0.1", port + 1))
            except OSError:
                continue
        return port


def test_one_sim_serves_several_vehicles_numbered_as_px4_does(vehicles: list[subprocess.Popen[str]]) -> None:
    port = _two_free_ports()
    proc = start_sim("--vehicles", "2", "--sysid", "7", "--spacing", "30", "--bind", f"127.0.0.1:{port}",
                     "--gcs", "none", "--api", "none")  # fmt: skip
    vehicles.append(proc)
    assert listening_port(proc) == port
    second = read_line(proc.stdout, 30.0)
    assert second is not None and f"listening on 127.0.0.1:{port + 1}; system id 8;" in second
    urls = [f"udp://127.0.0.1:{port + i}" for i in range(2)]
    area = [(ORIGIN.lat_deg, ORIGIN.lon_deg)]
    fleet = find_fleet(urls, ORIGIN, area)
    assert [(v.uav, v.url) for v in fleet] == [("uav-7", urls[0]), ("uav-8", urls[1])]
    assert [round(v.east_m, 1) for v in fleet] == [0.0, 30.0] and all(abs(v.north_m) < 0.1 for v in fleet)


def test_several_vehicles_refuse_what_is_for_one_and_run_out_of_system_ids(capsys: Any) -> None:
    assert sim_main(["--vehicles", "2", "--resume", "snapshot.json"]) == 2
    assert "--resume and --state-dir are for one" in capsys.readouterr().err
    assert sim_main(["--vehicles", "3", "--sysid", "254", "--bind", "127.0.0.1:0"]) == 2
    assert "system ids 254 to 256: at most 255" in capsys.readouterr().err
    with pytest.raises(SystemExit) as usage:
        sim_main(["--vehicles", "0"])
    assert usage.value.code == 2 and "1 to 255" in capsys.readouterr().err


def test_far_means_outside_the_area_not_far_from_its_corners(monkeypatch: pytest.MonkeyPatch) -> None:
    wide = [offset_position(ORIGIN.lat_deg, ORIGIN.lon_deg, n, e) for n, e in ((-5e3, -5e3), (5e3, -5e3), (5e3, 5e3),
                                                                             (-5e3, 5e3))]  # fmt: skip
    homes = {"udp://127.0.0.1:1": (ORIGIN.lat_deg, ORIGIN.lon_deg), "udp://127.0.0.1:2": offset_position(
        ORIGIN.lat_deg, ORIGIN.lon_deg, 0.0, 7.5e3)}  # fmt: skip
    answers = {url: (n + 1, (*home, 300.0)) for n, (url, home) in enumerate(homes.items())}
    monkeypatch.setattr(swarm_connect, "_probe_all", lambda urls, _t, _key: [answers[u] for u in urls])
    (inside,) = find_fleet(["udp://127.0.0.1:1"], ORIGIN, wide)  # 7 km from every corner, but inside
    assert inside.system_id == 1
    with pytest.raises(InputError, match=r"is 2\.5 km from the mission's area"):
        find_fleet(list(homes), ORIGIN, wide)
