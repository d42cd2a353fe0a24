"""The shipped person detector: its weights match their recipe, it loads through ``load_ours`` with the recipe's
calibration and threshold, and a copy whose bytes changed is refused by name."""

from __future__ import annotations

import hashlib
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
