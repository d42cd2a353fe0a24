"""``agentic-uav run --connect URL`` with a link signed otherwise than ``--signing-key`` says is refused before
anything flies, saying so — the vehicle signs with another key, signs while the run has no key, or does not sign
while the run has one — at once, not as a vehicle that never answered after the connection's 10 s."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.run.link_probe import signing_problem
from flight.signing import new_key, write_key_file
from tests.flight.test_cli import free_udp_port
from tests.flight.test_cli_vehicle import listening_port, start_sim, stop

from .swarm_missions import ORIGIN

EMERGENCY = Path(__file__).resolve().parents[3] / "missions" / "hajj_emergency.yaml"


def _key(path: Path) -> Path:
    write_key_file(path, new_key())
    return path


@pytest.fixture
def vehicle_key(tmp_path: Path) -> Path:
    return _key(tmp_path / "vehicle.key")


class Sim:
    """One ``agentic-uav sim`` process, stopped at the end (exit 0, or the test fails)."""

    def __init__(self) -> None:
        self.proc: Any = None

    def start(self, *sign: str) -> str:
        port = free_udp_port()
        self.proc = start_sim("--bind", f"127.0.0.1:{port}", "--gcs", "none", "--api", "none",
                              "--home", f"{ORIGIN.lat_deg},{ORIGIN.lon_deg},300", *sign)  # fmt: skip
        assert listening_port(self.proc) == port
        return f"udp://127.0.0.1:{port}"


@pytest.fixture
def sim() -> Iterator[Sim]:
    started = Sim()
    yield started
    if started.proc is not None:
        code, _out, err = stop(started.proc)
        assert code == 0, err


CASES = {
    "another key": (True, True, "signs with another key than --signing-key's"),
    "run unsigned": (True, False, "signs its link and refuses unsigned commands: give its key with --signing-key"),
    "vehicle unsigned": (False, True, "does not sign its link (it has no key)"),
}


@pytest.mark.timeout(60)
@pytest.mark.parametrize("case", list(CASES))
def test_a_link_signed_otherwise_is_said_so_and_nothing_flies(
    case: str, sim: Sim, vehicle_key: Path, tmp_path: Path, capsys: Any
) -> None:
    vehicle_signs, run_signs, says = CASES[case]
    url = sim.start(*(["--signing-key", str(vehicle_key)] if vehicle_signs else []))
    sign = ["--signing-key", str(_key(tmp_path / "run.key"))] if run_signs and vehicle_signs else []
    if run_signs and not vehicle_signs:
        sign = ["--signing-key", str(vehicle_key)]
    runs = tmp_path / "runs"
    began = time.monotonic()
    code = main(["run", str(EMERGENCY), "--connect", url, *sign, "--runs-dir", str(runs), "--quiet",
                 "--camera-hz", "2"])  # fmt: skip
    took = time.monotonic() - began
    err = capsys.readouterr().err
    assert code == 1 and "Traceback" not in err, err
    assert f"--connect {url}: the vehicle (system id 1) {says}" in err, err
    assert "cannot reach the vehicle" not in err
    assert took < 9.0  # said at once, not after the connection's 10 s without an answer
    (run_dir,) = runs.iterdir()
    trace = (run_dir / "trace.jsonl").read_text(encoding="utf-8")
    assert "flight.takeoff" not in trace and "flight.set_fence" not in trace  # nothing was sent to fly


@pytest.mark.timeout(60)
def test_the_right_key_passes_the_probe_and_the_vehicle_refuses_nothing(
    sim: Sim, vehicle_key: Path, tmp_path: Path
) -> None:
    url = sim.start("--signing-key", str(vehicle_key))
    assert signing_problem(url, bytes.fromhex(vehicle_key.read_text())) is None
    code, out, err = stop(sim.proc)
    sim.proc = None
    assert code == 0, err
    assert "refused nothing" in out  # the probe's heartbeat goes unsigned, as PX4 takes it; its request signed
