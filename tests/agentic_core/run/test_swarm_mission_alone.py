"""A swarm mission given to ``agentic-uav run`` (one drone) is refused at once: exit 2, naming the file and the line
of its ``swarm:`` block and the command that flies it, and no run directory is made."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from agentic_core.cli import main

REPO = Path(__file__).resolve().parents[3]


def test_a_swarm_mission_run_alone_says_to_use_swarm_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = tmp_path / "my swarm.yaml"
    text = (REPO / "missions" / "hajj_swarm.yaml").read_text(encoding="utf-8")
    mission.write_text("# moved down a line\n" + text, encoding="utf-8")
    line = next(n for n, row in enumerate(mission.read_text(encoding="utf-8").splitlines(), 1) if row == "swarm:")
    runs = tmp_path / "runs"
    code = main(["run", str(mission), "--runs-dir", str(runs)])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{mission}:{line}:" in err and f"agentic-uav swarm run {mission}" in err
    assert "Traceback" not in err and "unknown tool" not in err
    assert not runs.exists() or not any(runs.iterdir())


def test_a_one_drone_mission_is_not_taken_for_a_swarm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = tmp_path / "swarm.yaml"  # the name says swarm; only a top-level swarm: block makes one
    shutil.copy(REPO / "missions" / "hajj_swarm.yaml", mission)
    text = mission.read_text(encoding="utf-8").replace("\nswarm:", "\nnot_swarm:", 1)
    mission.write_text(text + "\nnotes: {swarm: 1}\n", encoding="utf-8")
    code = main(["run", str(mission), "--runs-dir", str(tmp_path / "runs")])
    err = capsys.readouterr().err
    assert code == 2 and "swarm run" not in err and str(mission) in err  # the loader's own error, not ours
