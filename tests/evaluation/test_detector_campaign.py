"""``eval campaign --detector ours``: the episode runs the shipped detector on rendered frames, the manifest says so,
and the ground-truth counts come from that pipeline (persons in view are counted, tracks matched to them)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

pytest.importorskip("onnxruntime")

from agentic_core.cli import main
from evaluation.campaign import read_records
from tests.evaluation.campaign_scenes import write_scenes


@pytest.mark.slow
def test_a_campaign_with_our_detector(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "scenes").mkdir()
    scenes = write_scenes(tmp_path / "scenes", first_seed=500, persons=150, prefix="det", count=1)
    out = tmp_path / "c"
    args = ["eval", "campaign", "--scene-file", *scenes, "--frames", "12", "--systems", "rules", "--out", str(out)]
    assert main([*args, "--detector", "ours", "--quiet", "--no-stats"]) == 0, capsys.readouterr().err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["detector"] == "ours" and manifest["settings"]["camera"]["width_px"] == 640
    (record,) = read_records(out / "results.jsonl")
    assert record.persons_in_view > 0 and record.detection_tp + record.detection_fn == record.persons_in_view
