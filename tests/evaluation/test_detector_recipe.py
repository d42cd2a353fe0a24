"""The one-command recipe for the shipped detector: its stages chain each one's output folder into the next, each
stage is timed into the final recipe, a failing stage stops it with its status, and bad arguments are refused."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import pytest

from evaluation.detector.recipe import Stage, main, run, stages

pytestmark = pytest.mark.timeout(60)


def _flag(argv: tuple[str, ...], name: str) -> str:
    return argv[argv.index(name) + 1]


def test_each_stage_reads_the_folder_the_one_before_it_wrote(tmp_path: Path) -> None:
    plan = stages(tmp_path, train_minutes=7.5, threads=1)
    assert [s.module for s in plan] == [f"evaluation.detector.{n}" for n in ("train", "quantise", "box_refit",
                                                                           "rescue_fit", "report")]  # fmt: skip
    train, quantise, refit, rescue, report = (s.argv for s in plan)
    assert _flag(quantise, "--src") == _flag(train, "--out")
    assert _flag(refit, "--src") == _flag(quantise, "--out")
    assert _flag(rescue, "--src") == _flag(refit, "--out")
    assert _flag(report, "--weights") == _flag(rescue, "--out") == str(tmp_path / "final")
    assert _flag(train, "--max-minutes") == "7.5" and _flag(train, "--threads") == "1"
    assert {"--context32", "--neighbour-boxes"} <= set(train) and "--steps" not in train
    counted = stages(tmp_path, threads=1, train_steps=500)[0].argv
    assert _flag(counted, "--steps") == "500" and "--max-minutes" not in counted and "--max-cpu-minutes" not in counted


def _fake_stage(folder: Path, name: str, body: str) -> str:
    (folder / f"{name}.py").write_text(f"import json, pathlib\n\ndef main(argv):\n{body}\n")
    return name


def test_every_stage_is_timed_into_the_final_recipe(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(tmp_path))
    final = tmp_path / "final"
    write = _fake_stage(tmp_path, "fake_write", "    p = pathlib.Path(argv[0])\n    p.mkdir(parents=True)\n"
                        "    (p / 'person.json').write_text(json.dumps({'sha256': 'x'}))\n    return 0")  # fmt: skip
    nothing = _fake_stage(tmp_path, "fake_nothing", "    return 0")
    lines: list[str] = []
    made = run([Stage("one", write, (str(final),)), Stage("two", nothing, ())], final, log=lines.append)
    assert set(made) == {"one", "two", "total"}
    assert made["total"]["seconds"] == pytest.approx(made["one"]["seconds"] + made["two"]["seconds"], abs=0.11)
    recipe = json.loads((final / "person.json").read_text())
    assert recipe["sha256"] == "x" and recipe["made"]["stages"] == made and recipe["made"]["cpus"] == os.cpu_count()
    assert lines[0].startswith("== one: python -m fake_write") and lines[-1].startswith("== two:")


def test_a_failing_stage_stops_the_recipe_with_its_status(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(tmp_path))
    fail = _fake_stage(tmp_path, "fake_fail", "    return 3")
    after = _fake_stage(tmp_path, "fake_after", "    raise AssertionError('ran after a failed stage')")
    with pytest.raises(SystemExit) as stopped:
        run([Stage("fails", fail, ()), Stage("after", after, ())], tmp_path / "final", log=lambda _: None)
    assert stopped.value.code == 3
    assert not (tmp_path / "final").exists()
    sys.modules.pop("fake_fail", None)


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["--train-minutes", "0"], "--train-minutes"),
        (["--threads", "0"], "--threads"),
        (["--train-steps", "0"], "--train-steps"),
        (["--train-steps", "many"], "--train-steps"),
    ],
)
def test_bad_arguments_are_refused_with_status_2(
    argv: list[str], said: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as refused:
        main(["--out", str(tmp_path / "out"), *argv])
    assert refused.value.code == 2 and said in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_report_says_what_the_recipe_took_and_nothing_when_it_was_not_made_by_it() -> None:
    from evaluation.detector.report import _description

    made = {"train": {"seconds": 1350.0, "cpu_seconds": 2340.0}, "report": {"seconds": 60.0, "cpu_seconds": 60.0}}
    made["total"] = {"seconds": 1410.0, "cpu_seconds": 2400.0}
    recipe: dict[str, Any] = {
        "sha256": "0" * 64, "config": {}, "training": {}, "calibration_data": {"frames": 2},
        "made": {"command": "python -m evaluation.detector.recipe", "cpus": 2, "stages": made},
    }  # fmt: skip
    (line,) = [t for t in _description(recipe, 0.3) if t.startswith("- made from nothing")]
    assert "in 23.5 min of wall time (40.0 CPU min) on a 2-core machine" in line
    assert "render and train 22.5, report 1.0" in line and "wall-clock budget decides how many steps" in line
    recipe["config"]["steps"], recipe["training"]["stopped_by"] = 500, "steps"
    text = _description(recipe, 0.3)
    assert "a fixed step count, so the same command makes the same weights" in text[2]
    assert "ended by a fixed step count" in next(t for t in text if t.startswith("- training:"))
    del recipe["made"]
    assert not [t for t in _description(recipe, 0.3) if "made from nothing" in t]
