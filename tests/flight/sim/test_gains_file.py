"""Controller gains from a file (``--gains``, the tune.json of ``eval tune``): what is read reaches the simulated
vehicle's controller, and every bad file is refused naming the file and the field, before anything flies."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agentic_core.cli import main as agentic_main
from agentic_core.run.backends import SimBackend
from agentic_core.run.runner import MissionRun
from agentic_core.run.settings import RunSettings
from flight.cli import main as sim_main
from flight.sim.controller import Gains
from flight.sim.gains_file import TUNABLE, GainsFileError, load_gains

REPO = Path(__file__).resolve().parents[3]
SQUARE = REPO / "missions" / "examples" / "square_15m.yaml"


def write(tmp_path: Path, data: object, name: str = "tune.json") -> Path:
    path = tmp_path / name
    path.write_text(data if isinstance(data, str) else json.dumps(data), encoding="utf-8")
    return path


def test_a_tune_report_sets_its_gains_and_leaves_the_others(tmp_path: Path) -> None:
    report = {"accepted": True, "candidate": {"pos_xy": 1.1}, "gains": {"pos_xy": 1.1, "vel_xy_d": 0.1}}
    gains = load_gains(write(tmp_path, report))
    assert gains == Gains(pos_xy=1.1, vel_xy_d=0.1)
    assert load_gains(write(tmp_path, {"vel_xy_i": 0}, "plain.json")).vel_xy_i == 0.0


def test_the_tuner_searches_exactly_the_ranges_a_file_may_set() -> None:
    from evaluation.tuning.tuner import BOUNDS

    assert BOUNDS == TUNABLE
    for name, (low, high) in TUNABLE.items():
        assert low <= getattr(Gains(), name) <= high  # the defaults are inside


@pytest.mark.parametrize(
    ("data", "said"),
    [
        ({"gains": {"att": 9.0}}, "gains.att: not a tunable gain"),
        ({"pos_xy": 5.0}, "pos_xy: 5 is outside its safe range 0.3 to 1.6"),
        ({"vel_xy_d": -0.01}, "vel_xy_d: -0.01 is outside its safe range"),
        ('{"pos_xy": NaN}', "pos_xy: expected a finite number, got nan"),
        ('{"pos_xy": Infinity}', "pos_xy: expected a finite number"),
        ({"pos_xy": True}, "pos_xy: expected a finite number, got True"),
        ({"pos_xy": "0.9"}, "pos_xy: expected a finite number, got '0.9'"),
        ({"gains": {}}, "expected an object of gains"),
        ([0.9], "expected an object of gains"),
        ("{not json", "not JSON"),
        ("\udcff", "not JSON"),
    ],
)
def test_a_bad_gains_file_is_refused_naming_the_file_and_the_field(tmp_path: Path, data: object, said: str) -> None:
    path = tmp_path / "g.json"
    if isinstance(data, str):
        path.write_bytes(data.encode("utf-8", "surrogateescape"))
    else:
        path.write_text(json.dumps(data), encoding="utf-8")
    with pytest.raises(GainsFileError) as caught:
        load_gains(path)
    assert str(path) in str(caught.value) and said in str(caught.value)


def test_a_missing_or_huge_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(GainsFileError, match="cannot read the gains file"):
        load_gains(tmp_path / "none.json")
    huge = tmp_path / "huge.json"
    huge.write_text('{"pos_xy": 0.9' + " " * (1 << 20) + "}", encoding="utf-8")
    with pytest.raises(GainsFileError, match="larger than"):
        load_gains(huge)


def test_the_run_flies_its_simulated_vehicle_with_the_file_s_gains(tmp_path: Path) -> None:
    path = write(tmp_path, {"gains": {"pos_xy": 1.2, "vel_xy_p": 3.0}})
    run = MissionRun(RunSettings(mission=SQUARE, runs_dir=tmp_path / "runs", gains=path))
    try:
        assert isinstance(run.backend, SimBackend)
        assert run.backend.sim.controller.gains == Gains(pos_xy=1.2, vel_xy_p=3.0)
    finally:
        run.close()


def test_run_and_sim_refuse_a_bad_gains_file_before_starting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = write(tmp_path, {"pos_xy": 9})
    runs = tmp_path / "runs"
    assert agentic_main(["run", str(SQUARE), "--gains", str(bad), "--runs-dir", str(runs)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}: pos_xy: 9 is outside its safe range" in err and "Traceback" not in err
    assert not runs.exists()
    good = write(tmp_path, {"pos_xy": 0.9}, "good.json")
    argv = ["run", str(SQUARE), "--gains", str(good), "--connect", "udp://127.0.0.1:9", "--runs-dir", str(runs)]
    assert agentic_main(argv) == 2
    assert "--gains sets the simulated vehicle's controller" in capsys.readouterr().err
    assert sim_main(["--gains", str(bad), "--gcs", "none", "--api", "127.0.0.1:0", "--bind", "127.0.0.1:0"]) == 2
    assert f"{bad}: pos_xy: 9 is outside" in capsys.readouterr().err
