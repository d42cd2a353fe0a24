"""Choosing the rescue of crowded persons: the scores before the peak test become a second output (the first
unchanged), a model without a peak test is refused by name, the rescue kept is one the calibration renders allow
(F1 up, precision at most the allowed loss lower), and the recipe names it with the new SHA-256 and the old."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from agentic_core.perception.detectors.ours import load_ours, weights_dir  # noqa: E402
from agentic_core.perception.detectors.yolo_decode import letterbox  # noqa: E402
from evaluation.detector.rescue_fit import MAX_PRECISION_LOSS, OUTPUT, cells, choose, main, with_scores_output  # noqa: E402
from evaluation.detector.train import TrainConfig, render_frames, sha256_of  # noqa: E402


def _without_scores(tmp_path: Path) -> Path:
    proto = onnx.load(str(weights_dir() / "person.onnx"))
    del proto.graph.output[1:]
    proto.graph.node.remove(next(n for n in proto.graph.node if OUTPUT in n.output))
    onnx.save(proto, str(tmp_path / "plain.onnx"))
    return tmp_path / "plain.onnx"


def test_the_scores_before_the_peak_test_become_a_second_output(tmp_path: Path) -> None:
    plain = _without_scores(tmp_path)
    assert with_scores_output(plain, tmp_path / "out.onnx") == 160
    image = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=9, count=1)[0].image
    tensor, _ = letterbox(image, (640, 480))
    first = ort.InferenceSession(str(plain), providers=["CPUExecutionProvider"]).run(None, {"images": tensor})
    second = ort.InferenceSession(str(tmp_path / "out.onnx"), providers=["CPUExecutionProvider"])
    assert [o.name for o in second.get_outputs()][1] == OUTPUT
    output, before = second.run(None, {"images": tensor})
    assert len(first) == 1 and np.array_equal(first[0], output)
    peak = output[0, 4]
    assert (before.reshape(-1) >= peak).all() and np.array_equal(before.reshape(-1)[peak > 0], peak[peak > 0])


def test_a_model_without_a_peak_test_is_refused(tmp_path: Path) -> None:
    proto = onnx.load(str(_without_scores(tmp_path)))
    next(n for n in proto.graph.node if n.op_type == "MaxPool").op_type = "AveragePool"
    onnx.save(proto, str(tmp_path / "no_peaks.onnx"))
    with pytest.raises(ValueError, match="no 3×3 peak test over the scores"):
        with_scores_output(tmp_path / "no_peaks.onnx", tmp_path / "out.onnx")


def test_the_rescue_kept_is_one_the_calibration_renders_allow(tmp_path: Path) -> None:
    frames = render_frames(TrainConfig(altitudes_m=(40.0, 50.0)), seed=2, count=2)
    rescue, report = choose(cells(weights_dir() / "person.onnx", frames), frames, 160)
    base = report["without"]
    assert len(report["tried"]) == 36
    if rescue is None:
        assert all(t["f1"] <= base["f1"] or t["precision"] < base["precision"] - MAX_PRECISION_LOSS
                   for t in report["tried"])  # fmt: skip
    else:
        kept = next(t for t in report["tried"] if (t["min_score"], t["centre_ratio"], t["min_long_px"])
                    == (rescue.min_score, rescue.centre_ratio, rescue.min_long_px))  # fmt: skip
        assert kept["f1"] > base["f1"] and kept["precision"] >= base["precision"] - MAX_PRECISION_LOSS
        allowed = [t["f1"] for t in report["tried"] if t["precision"] >= base["precision"] - MAX_PRECISION_LOSS]
        assert kept["f1"] == max(allowed)


def test_the_recipe_names_the_rescue_and_both_weights(tmp_path: Path) -> None:
    src, out = tmp_path / "src", tmp_path / "out"
    shutil.copytree(weights_dir(), src)
    (src / "person.onnx").write_bytes(_without_scores(tmp_path).read_bytes())
    recipe = json.loads((src / "person.json").read_text())
    recipe.pop("rescue", None)
    recipe["sha256"] = sha256_of(src / "person.onnx")
    (src / "person.json").write_text(json.dumps(recipe))
    assert main(["--src", str(src), "--out", str(out), "--frames", "3"]) == 0
    written = json.loads((out / "person.json").read_text())
    assert written["sha256"] == sha256_of(out / "person.onnx") != recipe["sha256"]
    if "rescue" in written:
        assert written["rescue"]["before_sha256"] == recipe["sha256"]
        assert written["rescue"]["chosen_on"] == {"seed": 2, "frames": 3, "max_precision_loss": MAX_PRECISION_LOSS}
        assert load_ours(out).rescue is not None
    else:
        assert load_ours(out).rescue is None
