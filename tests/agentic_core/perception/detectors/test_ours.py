"""The shipped person detector: its weights match their recipe, it loads through ``load_ours`` with the recipe's
calibration and threshold, and a copy whose bytes changed, or whose recipe holds a broken calibration, is refused by
name."""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.perception.detectors.ours import RECIPE, WEIGHTS, load_ours, read_recipe, weights_dir

pytest.importorskip("onnxruntime")


def test_the_shipped_weights_match_their_recipe_and_load() -> None:
    recipe = read_recipe()
    assert hashlib.sha256((weights_dir() / WEIGHTS).read_bytes()).hexdigest() == recipe["sha256"]
    detector = load_ours()
    assert detector.score_threshold == recipe["score_threshold"] and detector.input_size == (640, 480)
    assert detector.calibration.scores == recipe["calibration"]["scores"]
    assert len(detector.calibration.by_size) == len(recipe["calibration"]["size_edges_px"]) + 1 > 1  # by box size
    boxes, scores, labels = detector.detect_array(np.full((480, 640, 3), 128, np.uint8))
    assert len(boxes) == len(scores) == len(labels)


def test_a_changed_copy_is_refused(tmp_path: Path) -> None:
    shutil.copy(weights_dir() / RECIPE, tmp_path / RECIPE)
    data = bytearray((weights_dir() / WEIGHTS).read_bytes())
    data[len(data) // 2] ^= 1
    (tmp_path / WEIGHTS).write_bytes(bytes(data))
    with pytest.raises(InputError, match=r"person\.onnx: SHA-256 [0-9a-f]{64} is not the recipe's"):
        load_ours(tmp_path)


@pytest.mark.parametrize(
    ("change", "said"),
    [
        ({"size_edges_px": [10.0]}, r"calibration: Value error, calibration: 1 size edges need 2 maps in by_size"),
        ({"by_size": [{"scores": [0.5], "probs": [2.0]}]}, r"calibration: Value error, calibration: by_size\[0\]"),
        ({"scores": "high"}, r"calibration\.scores: Input should be a valid list"),
    ],
)
def test_a_recipe_with_a_broken_calibration_is_refused_by_name(
    tmp_path: Path, change: dict[str, object], said: str
) -> None:
    shutil.copy(weights_dir() / WEIGHTS, tmp_path / WEIGHTS)
    recipe = read_recipe()
    recipe["calibration"] = {**recipe["calibration"], **change}
    (tmp_path / RECIPE).write_text(json.dumps(recipe))
    with pytest.raises(InputError, match=r"person\.json: " + said):
        load_ours(tmp_path)
