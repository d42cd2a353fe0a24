"""Crowded persons given back: a removed cell comes back only when it scores enough, is big enough and no higher
neighbour predicts its centre; a peak is never touched; a neighbour is a neighbour on the grid, not the next cell in
memory across a row's end; bad recipe entries and a missing output are refused by name."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.perception.detectors.rescue import Rescue, rescued_scores

F = np.float32
RESCUE = Rescue(output="scores", min_score=0.5, centre_ratio=0.7, min_long_px=8.0, grid_width=4)


def _grid(before: dict[int, float], boxes: dict[int, list[float]], peaks: set[int]) -> tuple[np.ndarray, ...]:
    """A 3×4 grid: each cell's box (a default far away for the unnamed), its score before and after the peak test."""
    b = np.array([[100.0 * i, 0, 100.0 * i + 10, 20] for i in range(12)], F)
    for i, box in boxes.items():
        b[i] = box
    s = np.zeros(12, F)
    for i, v in before.items():
        s[i] = v
    return b, np.where(np.isin(np.arange(12), list(peaks)), s, 0).astype(F), s


def test_a_cell_whose_higher_neighbour_is_someone_else_comes_back() -> None:
    boxes, peak, before = _grid({5: 0.9, 6: 0.6}, {5: [0, 0, 10, 20], 6: [30, 0, 40, 20]}, {5})
    out = rescued_scores(boxes, peak, before, RESCUE)
    assert out[5] == before[5] and out[6] == before[6]


def test_a_duplicate_of_the_same_person_stays_removed() -> None:
    boxes, peak, before = _grid({5: 0.9, 6: 0.8}, {5: [0, 0, 10, 20], 6: [1, 1, 11, 21]}, {5})
    assert rescued_scores(boxes, peak, before, RESCUE)[6] == 0


@pytest.mark.parametrize(
    ("score", "box", "why"),
    [(0.49, [30, 0, 40, 20], "under min_score"), (0.8, [30, 0, 37, 6], "box under min_long_px")],
)
def test_a_weak_or_small_cell_stays_removed(score: float, box: list[float], why: str) -> None:
    boxes, peak, before = _grid({5: 0.9, 6: score}, {5: [0, 0, 10, 20], 6: box}, {5})
    assert rescued_scores(boxes, peak, before, RESCUE)[6] == 0, why


def test_peaks_are_never_touched_and_no_score_rises_above_its_own() -> None:
    rng = np.random.default_rng(3)
    corner = rng.uniform(0, 60, (12, 2))
    boxes = np.column_stack([corner, corner + rng.uniform(4, 30, (12, 2))]).astype(F)
    before = rng.uniform(0, 1, 12).astype(F)
    peak = np.where(rng.random(12) < 0.3, before, 0).astype(F)
    out = rescued_scores(boxes, peak, before, RESCUE)
    assert (out[peak > 0] == peak[peak > 0]).all()
    assert ((out == 0) | (out == before)).all() and (out >= peak).all()


def test_the_end_of_a_row_is_not_next_to_the_start_of_the_next() -> None:
    # cell 3 ends row 0, cell 4 starts row 1: adjacent in memory, far apart on the grid; same predicted centre
    boxes, peak, before = _grid({3: 0.6, 4: 0.9}, {3: [0, 0, 10, 20], 4: [0, 0, 10, 20]}, {4})
    assert rescued_scores(boxes, peak, before, RESCUE)[3] == before[3]
    boxes, peak, before = _grid({3: 0.6, 7: 0.9}, {3: [0, 0, 10, 20], 7: [0, 0, 10, 20]}, {7})  # 7 is below 3
    assert rescued_scores(boxes, peak, before, RESCUE)[3] == 0


def test_arrays_that_do_not_fill_the_grid_are_refused() -> None:
    boxes, peak, before = _grid({}, {}, set())
    with pytest.raises(ValueError, match="do not fill a grid 5 wide"):
        rescued_scores(boxes, peak, before, Rescue("scores", 0.5, 0.7, 8.0, 5))
    with pytest.raises(ValueError, match="11 and 12 scores"):
        rescued_scores(boxes, peak[:11], before, RESCUE)


@pytest.mark.parametrize(
    ("entry", "field"),
    [
        ({"min_score": 0.5, "centre_ratio": 0.7, "min_long_px": 8, "grid_width": 160}, "rescue.output"),
        ({"output": "scores", "min_score": "0.5", "centre_ratio": 0.7, "min_long_px": 8, "grid_width": 160},
         "rescue.min_score"),
        ({"output": "scores", "min_score": 0.5, "centre_ratio": True, "min_long_px": 8, "grid_width": 160},
         "rescue.centre_ratio"),
        ({"output": "scores", "min_score": 0.5, "centre_ratio": 0.7, "min_long_px": 8, "grid_width": 160.0},
         "rescue.grid_width"),
        ({"output": "scores", "min_score": 0.5, "centre_ratio": 0.7, "min_long_px": 8, "grid_width": 0},
         "rescue.grid_width"),
        ([1, 2], "rescue must be an object"),
    ],
)  # fmt: skip
def test_a_bad_recipe_entry_is_refused_naming_the_recipe_and_field(entry: object, field: str) -> None:
    with pytest.raises(InputError, match=f"person.json: {field}"):
        Rescue.from_recipe(entry, Path("weights/person.json"))


def test_a_rescue_naming_an_output_the_model_lacks_is_refused(tmp_path: Path) -> None:
    pytest.importorskip("onnxruntime")
    from agentic_core.perception.detectors import OnnxDetector
    from agentic_core.perception.detectors.ours import weights_dir

    with pytest.raises(InputError, match="no output 'nope' to rescue crowded persons from"):
        OnnxDetector(weights_dir() / "person.onnx", rescue=Rescue("nope", 0.5, 0.7, 8.0, 160))


def test_the_shipped_rescue_finds_at_least_as_many_in_a_crowd() -> None:
    pytest.importorskip("onnxruntime")
    from agentic_core.perception.detectors import OnnxDetector
    from agentic_core.perception.detectors.ours import load_ours, weights_dir
    from evaluation.detector.evaluate import ignored
    from evaluation.detector.scoring import match, precision_at, recall_of
    from evaluation.detector.train import TrainConfig, render_frames

    ours = load_ours()
    recipe = json.loads((weights_dir() / "person.json").read_text())
    if ours.rescue is None:
        pytest.skip("the shipped recipe names no rescue")
    assert recipe["rescue"]["output"] in [o.name for o in ours.session.get_outputs()]
    plain = OnnxDetector(ours.path, layout="v8", class_names=["person"], score_threshold=ours.score_threshold,
                         max_detections=ours.max_detections)  # fmt: skip
    frames = render_frames(TrainConfig(altitudes_m=(50.0,)), seed=9, count=2)
    truth, skip = [f.boxes for f in frames], ignored(frames)
    with_, without = (match([d.detect_array(f.image)[:2] for f in frames], truth, skip) for d in (ours, plain))
    t = ours.score_threshold
    assert recall_of(with_, t) > recall_of(without, t)
    assert precision_at(with_, t) >= precision_at(without, t) - 0.03
