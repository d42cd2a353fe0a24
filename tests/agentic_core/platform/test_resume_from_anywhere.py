"""``run.json`` names every file a run reads by its absolute path, so ``--resume RUN_ID`` works from any folder:
before, a run started with ``run m.yaml --tools t.py`` from one folder could be resumed only from that folder
("m.yaml: cannot read the file")."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.run.runner import resume_run, run_mission
from agentic_core.run.settings import RunSettings
from agentic_core.run.state_files import anchored, read_record

pytestmark = pytest.mark.timeout(180)

HOP = """
plan_id: hop
goal: up and down
steps:
  - {id: up, action: takeoff, args: {altitude_m: 3}}
  - {id: down, action: land, depends_on: [up]}
"""


def test_every_file_a_run_names_is_anchored_and_a_module_name_is_kept(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "t.py").write_text("", encoding="utf-8")
    settings = RunSettings(
        mission=Path("m.yaml"), scene=Path("s/scene.yaml"), gains=Path("tune.json"), signing_key=Path("k.hex"),
        memory=Path("mem.db"), tools=["t.py", "mypkg.tools"], detector="onnx:models/x.onnx",
    )  # fmt: skip
    fixed = anchored(settings)
    for path in (fixed.mission, fixed.scene, fixed.gains, fixed.signing_key, fixed.memory):
        assert path is not None and path.is_absolute() and path.is_relative_to(tmp_path)
    assert fixed.tools == [str(tmp_path / "t.py"), "mypkg.tools"]
    assert fixed.detector == f"onnx:{tmp_path / 'models' / 'x.onnx'}"
    assert anchored(RunSettings(mission=Path("m.yaml"), detector="ours")).detector == "ours"


def test_a_run_started_with_relative_paths_is_resumed_from_another_folder(tmp_path: Path, monkeypatch) -> None:
    started, elsewhere, runs = tmp_path / "missions", tmp_path / "elsewhere", tmp_path / "runs"
    started.mkdir()
    elsewhere.mkdir()
    (started / "hop.yaml").write_text(HOP, encoding="utf-8")
    monkeypatch.chdir(started)
    first = run_mission(RunSettings(mission=Path("hop.yaml"), runs_dir=runs, camera_hz=2.0, gcs="none"), progress=None)
    assert first.summary.outcome == "completed", first.summary
    assert read_record(runs, first.run_id).settings.mission == started / "hop.yaml"
    monkeypatch.chdir(elsewhere)
    again = resume_run(runs, first.run_id, progress=None)
    assert again.summary.outcome == "completed", again.summary
