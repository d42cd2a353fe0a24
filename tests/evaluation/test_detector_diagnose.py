"""Where persons are lost: each counted person of the pose in exactly one class, in the stated precedence; the
ignored and the other poses never classified; the found ones exactly those recall counts; and, on the shipped
model, the score before the peak test found in its graph and the classes adding up to the persons."""

from __future__ import annotations

import numpy as np
import pytest

from evaluation.detector.diagnose import CAUSES, CLASSES, breakdown, breakdown_lines, cells_session, classify
from evaluation.detector.scoring import match, recall_of

F = np.float32
TRUTH = np.array([[0, 0, 10, 20], [30, 0, 40, 20], [60, 0, 70, 20], [90, 0, 100, 20]], F)


def _dets(*rows: tuple[float, float, float, float, float]) -> tuple[np.ndarray, np.ndarray]:
    boxes = np.array([r[:4] for r in rows], F).reshape(-1, 4)
    return boxes, np.array([r[4] for r in rows], F)


NO_CELLS = (np.zeros((0, 4), F), np.zeros(0, F))


def _names(outcome: np.ndarray) -> list[str]:
    return [CLASSES[k] if k >= 0 else "not counted" for k in outcome]


def test_each_person_in_one_class_by_precedence() -> None:
    found = (0, 0, 10, 20, 0.9)
    under = (30, 0, 40, 20, 0.2)  # fits person 1, under the threshold ...
    wrong = (30, 5, 40, 14, 0.8)  # IoU 0.45 ... while a detection over it is of the wrong size: below threshold wins
    near = (60, 5, 70, 13, 0.7)  # IoU 0.4 with person 2
    c = classify(TRUTH, np.ones(4, bool), _dets(found, under, wrong, near), NO_CELLS, 0.5)
    assert _names(c.outcome) == ["found", "below threshold", "wrong box", "missed"]
    assert [CAUSES[k] for k in c.cause] == ["-", "unseen", "unseen", "unseen"]
    assert c.best_iou[2] == pytest.approx(0.4) and np.isnan(c.best_box[3]).all()


def test_a_fitting_box_matched_to_a_neighbour_is_taken_not_found() -> None:
    truth = np.array([[0, 0, 10, 20], [0, 2, 10, 22]], F)  # two persons, one box fits both
    c = classify(truth, np.ones(2, bool), _dets((0, 1, 10, 21, 0.9)), NO_CELLS, 0.5)
    assert sorted(_names(c.outcome)) == ["box taken", "found"]


def test_causes_come_from_the_cells_scores_before_the_peak_test() -> None:
    cells = (np.array([[30, 0, 40, 19], [60, 0, 70, 21], [90, 0, 100, 20]], F), np.array([0.7, 0.3, 0.9], F))
    dets = _dets((0, 0, 10, 20, 0.9), (90, 0, 100, 20, 0.9))
    c = classify(TRUTH, np.ones(4, bool), dets, cells, 0.5)
    assert _names(c.outcome) == ["found", "missed", "missed", "found"]
    assert [CAUSES[k] for k in c.cause] == [
        "-",
        "beaten",
        "weak",
        "-",
    ]  # a found person has no cause, fitting cell or not


def test_ignored_persons_and_other_poses_are_never_classified() -> None:
    dets = _dets((0, 0, 10, 20, 0.9), (30, 0, 40, 20, 0.9))
    ignore = np.array([True, False, False, False])
    chosen = np.array([True, True, False, True])
    c = classify(TRUTH, chosen, dets, NO_CELLS, 0.5, ignore)
    assert _names(c.outcome) == ["not counted", "found", "not counted", "missed"]
    assert c.cause.tolist() == [0, 0, 0, 3]


def test_found_are_exactly_the_persons_recall_counts() -> None:
    rng = np.random.default_rng(5)
    corners = rng.uniform(0, 200, (40, 2)).astype(F)
    truth = np.column_stack([corners, corners + rng.uniform(4, 20, (40, 2)).astype(F)])
    boxes = truth[rng.permutation(40)[:30]] + rng.normal(0, 2, (30, 4)).astype(F)
    scores = rng.uniform(0, 1, 30).astype(F)
    ignore = rng.random(40) < 0.2
    chosen = rng.random(40) < 0.6
    for threshold in (0.1, 0.5, 0.9):
        c = classify(truth, chosen, (boxes, scores), (boxes, scores), threshold, ignore)
        m = match([(boxes, scores)], [truth], [ignore])
        counted = chosen & ~ignore
        assert int(np.sum(c.outcome == 0)) == round(recall_of(m, threshold, [chosen]) * counted.sum())
        assert ((c.outcome >= 0) == counted).all()


def test_nothing_found_and_nothing_held_is_all_missed_and_unseen() -> None:
    c = classify(TRUTH, np.ones(4, bool), (np.zeros((0, 4), F), np.zeros(0, F)), NO_CELLS, 0.3)
    assert _names(c.outcome) == ["missed"] * 4 and [CAUSES[k] for k in c.cause] == ["unseen"] * 4


def test_the_shipped_model_breaks_down_and_adds_up() -> None:
    pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    from agentic_core.perception.detectors.ours import load_ours, weights_dir
    from evaluation.detector.evaluate import evaluate, pose_masks, scores_at
    from evaluation.detector.report import raw_detector
    from evaluation.detector.train import TrainConfig, render_frames

    session, name, before = cells_session(weights_dir() / "person.onnx")
    assert before is not None, "the export's peak test (a 3×3 max-pool over the scores) was not found"
    frames = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=9, count=2)
    out, pre = session.run(None, {name: np.zeros((1, 3, 480, 640), F)})
    assert (pre.reshape(-1) >= out[0, 4] - 1e-6).all()  # the peak test only ever zeroes a score
    detector, threshold = raw_detector(weights_dir()), load_ours().score_threshold
    b = breakdown(detector, frames, threshold, "lying")
    assert b.persons > 0 and sum(b.by_class.values()) == b.persons
    assert sum(b.by_cause.values()) == b.persons - b.by_class["found"]
    assert sum(n for _, n, _ in b.by_seen) == b.persons
    recall = scores_at(evaluate(detector, frames), threshold, pose_masks(frames, "lying")).recall
    assert b.by_class["found"] == round(recall * b.persons)
    lines = breakdown_lines(b)
    assert any(line.startswith("| found |") for line in lines) and any("beaten" in line for line in lines)
