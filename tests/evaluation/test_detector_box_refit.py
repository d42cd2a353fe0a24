"""Refitting the box rows: only the last convolution's four box rows change (every score, so every peak, the
calibration and the threshold stay bit for bit), the fit is no worse than the rows it replaces on what it fits, the
recipe names the new weights and the old, and a model that is not our export, or frames with no one to fit, are
refused by name."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

onnx = pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from onnx import numpy_helper  # noqa: E402

from agentic_core.perception.detectors.ours import load_ours, weights_dir  # noqa: E402
from agentic_core.perception.detectors.yolo_decode import letterbox  # noqa: E402
from evaluation.detector.box_refit import LAST_CONV, main, refit  # noqa: E402
from evaluation.detector.train import CachedFrame, TrainConfig, render_frames, sha256_of  # noqa: E402

SHIPPED = weights_dir() / "person.onnx"


@pytest.fixture(scope="module")
def refitted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, object]]:
    out = tmp_path_factory.mktemp("refit") / "person.onnx"
    frames = render_frames(TrainConfig(altitudes_m=(20.0, 30.0)), seed=1, count=3)
    return out, refit(SHIPPED, out, frames)


def _initialisers(path: Path) -> dict[str, np.ndarray]:
    return {i.name: numpy_helper.to_array(i) for i in onnx.load(str(path)).graph.initializer}


def _run(path: Path, image: np.ndarray) -> np.ndarray:
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    tensor, _ = letterbox(image, (640, 480))
    return np.asarray(session.run(None, {session.get_inputs()[0].name: tensor})[0])


def test_only_the_box_rows_change_and_every_score_stays(refitted: tuple[Path, dict[str, object]]) -> None:
    out, _ = refitted
    before, after = _initialisers(SHIPPED), _initialisers(out)
    assert before.keys() == after.keys()
    changed = {name for name in before if not np.array_equal(before[name], after[name])}
    assert changed == {"net.head.1.weight", "net.head.1.bias"}
    assert np.array_equal(before["net.head.1.weight"][0], after["net.head.1.weight"][0])
    assert before["net.head.1.bias"][0] == after["net.head.1.bias"][0]
    assert [n.name for n in onnx.load(str(SHIPPED)).graph.node] == [n.name for n in onnx.load(str(out)).graph.node]
    image = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=9, count=1)[0].image  # a scene the fit never saw
    old, new = _run(SHIPPED, image), _run(out, image)
    assert np.array_equal(old[0, 4], new[0, 4]) and (old[0, 4] > 0).sum() > 50  # the same peaks, the same scores
    assert not np.array_equal(old[0, 2:4], new[0, 2:4])


def test_the_fit_is_no_worse_than_the_rows_it_replaces(refitted: tuple[Path, dict[str, object]]) -> None:
    _, stats = refitted
    before, after = stats["mean_abs_error_before"], stats["mean_abs_error_after"]
    assert isinstance(before, dict) and isinstance(after, dict) and int(str(stats["samples"])) > 100
    for name in ("x offset", "y offset", "log width", "log height"):
        assert after[name] <= before[name] + 1e-3, name


def test_the_recipe_names_the_new_weights_and_the_old(tmp_path: Path) -> None:
    src, out = tmp_path / "src", tmp_path / "out"
    shutil.copytree(weights_dir(), src)
    assert main(["--src", str(src), "--out", str(out), "--frames", "2", "--extra-frames", "1"]) == 0
    recipe = json.loads((out / "person.json").read_text())
    old = json.loads((src / "person.json").read_text())
    assert recipe["sha256"] == sha256_of(out / "person.onnx") != old["sha256"]
    assert recipe["box_refit"]["before_sha256"] == old["sha256"]
    assert recipe["box_refit"]["data"] == {"seed": 1, "frames": 2, "extra_seed": 4, "extra_frames": 1}
    assert recipe["calibration"] == old["calibration"] and recipe["score_threshold"] == old["score_threshold"]
    assert load_ours(out).score_threshold == old["score_threshold"]  # its SHA-256 check passes


def test_a_model_that_is_not_our_export_is_refused(tmp_path: Path) -> None:
    proto = onnx.load(str(SHIPPED))
    for node in proto.graph.node:
        if node.name == LAST_CONV:
            node.name = "/renamed"
    onnx.save(proto, str(tmp_path / "other.onnx"))
    frames = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=1, count=1)
    with pytest.raises(ValueError, match=re.escape("no /net/head/head.1/Conv in the model")):
        refit(tmp_path / "other.onnx", tmp_path / "out.onnx", frames)


def test_frames_with_no_one_to_fit_are_refused(tmp_path: Path) -> None:
    empty = CachedFrame(
        np.full((480, 640, 3), 120, np.uint8), np.zeros((0, 4), np.float32), (), 30.0, np.zeros(0, np.float32)
    )
    with pytest.raises(ValueError, match="nothing to fit"):
        refit(SHIPPED, tmp_path / "out.onnx", [empty])
    assert not (tmp_path / "out.onnx").exists()
