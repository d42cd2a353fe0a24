"""Training smoke test: a few steps on a few rendered frames, exported to ONNX in a temporary folder, loads and runs
through the same path as the shipped detector, and a changed byte in the weights is refused by their SHA-256."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("onnx")
pytest.importorskip("onnxruntime")

from agentic_core.contracts.errors import InputError
from agentic_core.perception.detectors import OnnxDetector
from agentic_core.perception.detectors.ours import load_ours
from evaluation.detector.train import TrainConfig, export_onnx, main, render_frames, train, write_recipe


def test_a_few_steps_export_a_model_that_loads_and_runs(tmp_path: Path) -> None:
    config = TrainConfig(frames=3, width_px=320, height_px=240, crop_px=96, batch=4, crops_per_frame=2, epochs=1)
    frames = render_frames(config)
    assert len(frames) == 3 and frames[0].image.shape == (240, 320, 3)
    net, stats = train(frames, config, log=lambda _: None, max_steps=2)
    assert stats.steps == 1 or stats.steps == 2
    assert all(np.isfinite(stats.loss_by_epoch))
    digest = export_onnx(net, tmp_path / "person.onnx", width=320, height=240)
    write_recipe(tmp_path / "person.json", config, stats, digest)
    detector = OnnxDetector(tmp_path / "person.onnx", score_threshold=0.0)
    assert detector.input_size == (320, 240) and detector.class_names == ["person"]
    boxes, scores, labels = detector.detect_array(frames[0].image)
    assert boxes.shape[1] == 4 and len(scores) == len(labels) and set(labels) <= {"person"}
    assert np.all((boxes[:, 0] >= 0) & (boxes[:, 2] <= 320) & (boxes[:, 1] >= 0) & (boxes[:, 3] <= 240))
    ours = load_ours(tmp_path)
    assert ours.path == tmp_path / "person.onnx"
    recipe = json.loads((tmp_path / "person.json").read_text())
    assert recipe["sha256"] == digest and recipe["config"]["frames"] == 3 and recipe["training"]["steps"] >= 1


def test_changed_weights_are_refused(tmp_path: Path) -> None:
    config = TrainConfig(frames=2, width_px=320, height_px=240, crop_px=96, batch=2, crops_per_frame=1, epochs=1)
    net, stats = train(render_frames(config), config, log=lambda _: None, max_steps=1)
    digest = export_onnx(net, tmp_path / "person.onnx", width=320, height=240)
    write_recipe(tmp_path / "person.json", config, stats, digest)
    data = bytearray((tmp_path / "person.onnx").read_bytes())
    data[-10] ^= 0xFF
    (tmp_path / "person.onnx").write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"person\.onnx: SHA-256 [0-9a-f]{64} is not the recipe's " + digest):
        load_ours(tmp_path)
    (tmp_path / "person.onnx").unlink()
    with pytest.raises(InputError, match=r"person\.onnx: the shipped detector's weights are missing"):
        load_ours(tmp_path)
    (tmp_path / "person.json").write_text("{not json")
    with pytest.raises(InputError, match=r"person\.json: the detector's recipe cannot be read"):
        load_ours(tmp_path)
    (tmp_path / "person.json").write_text("{}")
    with pytest.raises(InputError, match=r"person\.json: the detector's recipe has no sha256"):
        load_ours(tmp_path)
    (tmp_path / "person.json").unlink()
    with pytest.raises(InputError, match=r"person\.json: the detector's recipe is missing"):
        load_ours(tmp_path)


def test_the_command_line_writes_weights_and_recipe(tmp_path: Path) -> None:
    args = ["--out", str(tmp_path), "--frames", "2", "--epochs", "1", "--batch", "2", "--crops-per-frame", "1"]
    assert main([*args, "--max-minutes", "0.05"]) == 0
    recipe = json.loads((tmp_path / "person.json").read_text())
    assert recipe["config"]["frames"] == 2 and (tmp_path / "person.onnx").is_file()
    assert main([*args, "--steps", "2"]) == 0
    recipe = json.loads((tmp_path / "person.json").read_text())
    assert recipe["config"]["steps"] == 2 and recipe["training"]["steps"] == 2
    assert recipe["training"]["stopped_by"] == "steps"


def test_a_step_budget_trains_the_same_weights_twice_and_a_time_budget_says_it_stopped_training() -> None:
    """``steps``: the schedule follows the steps alone, so two runs give the same weights (not so with a time
    budget, whose schedule follows the clock); a run cut short by the clock says which budget ended it."""
    import torch

    config = TrainConfig(frames=2, width_px=320, height_px=240, crop_px=96, batch=2, crops_per_frame=2, epochs=1,
                         threads=1, steps=3)  # fmt: skip
    frames = render_frames(config)
    (a, first), (b, second) = (train(frames, config, log=lambda _: None) for _ in range(2))
    assert first.steps == second.steps == 3 and first.epochs_done == 2  # 2 steps an epoch: past ``epochs=1``
    assert first.stopped_by == "steps" and first.loss_by_epoch == second.loss_by_epoch
    pairs = zip(a.state_dict().items(), b.state_dict().items(), strict=True)
    assert all(name == other and torch.equal(x, y) for (name, x), (other, y) in pairs)
    timed = TrainConfig(frames=2, width_px=320, height_px=240, crop_px=96, batch=2, crops_per_frame=2, epochs=50,
                        threads=1, max_minutes=1e-4)  # fmt: skip
    _, cut = train(frames, timed, log=lambda _: None)
    assert cut.stopped_by == "wall clock" and cut.steps < 50


def test_frames_rendered_in_parts_over_processes_are_those_rendered_in_one(monkeypatch: pytest.MonkeyPatch) -> None:
    import evaluation.detector.train as training

    monkeypatch.setattr(training, "RENDER_CHUNK", 8)
    config = TrainConfig(width_px=160, height_px=120, altitudes_m=(10.0, 30.0, 60.0))
    alone = render_frames(config, count=20, workers=1)
    apart = render_frames(config, count=20, workers=2)
    assert len(alone) == len(apart) == 20
    for a, b in zip(alone, apart, strict=True):
        assert np.array_equal(a.image, b.image) and np.array_equal(a.boxes, b.boxes) and a.poses == b.poses
        assert a.altitude_m == b.altitude_m and np.array_equal(a.visible, b.visible)
