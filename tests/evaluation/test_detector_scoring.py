"""Scoring with ignored persons (seen less than half): a detection on one is neither a hit nor a false alarm, an
ignored person is never one to find, a detection over both a counted and an ignored person is the counted one's,
and no detection hides behind an ignored person it does not overlap."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from evaluation.detector.crops import targets
from evaluation.detector.evaluate import best_threshold, scores_at
from evaluation.detector.scoring import average_precision, match, precision_at, recall_of
from flight.sim.render.dataset import MIN_SEEN

TRUTH = np.array([[0, 0, 10, 10], [40, 40, 50, 50], [80, 0, 90, 10]], np.float32)
IGNORE = [np.array([False, True, False])]


def _found(*rows: tuple[float, float, float, float, float]) -> list[tuple[np.ndarray, np.ndarray]]:
    boxes = np.array([r[:4] for r in rows], np.float32).reshape(-1, 4)
    return [(boxes, np.array([r[4] for r in rows], np.float32))]


def test_a_detection_on_an_ignored_person_is_neither_hit_nor_false_alarm() -> None:
    found = _found((0, 0, 10, 10, 0.9), (40, 40, 50, 50, 0.8), (41, 41, 51, 51, 0.7))
    m = match(found, [TRUTH], IGNORE)
    assert m.hit.tolist() == [True, False, False] and m.ignored.tolist() == [False, True, True]
    assert precision_at(m, 0.5) == 1.0
    assert recall_of(m, 0.5) == 0.5  # of the two counted persons, one found; the ignored one is not a target
    plain = match(found, [TRUTH])
    assert precision_at(plain, 0.5) == pytest.approx(2 / 3) and recall_of(plain, 0.5) == pytest.approx(2 / 3)


def test_an_ignored_person_missed_costs_nothing_and_a_stray_detection_still_does() -> None:
    m = match(_found((0, 0, 10, 10, 0.9), (80, 0, 90, 10, 0.8), (60, 60, 70, 70, 0.95)), [TRUTH], IGNORE)
    assert m.ignored.tolist() == [False, False, False]
    assert recall_of(m, 0.5) == 1.0 and precision_at(m, 0.5) == pytest.approx(2 / 3)
    assert scores_at(m, 0.5, [np.ones(3, bool)]).truth == 2


def test_a_detection_over_a_counted_and_an_ignored_person_is_the_counted_ones() -> None:
    truth = np.array([[0, 0, 10, 10], [0, 1, 10, 11]], np.float32)
    m = match(_found((0, 0.5, 10, 10.5, 0.9)), [truth], [np.array([True, False])])
    assert m.hit.tolist() == [True] and m.truth_index[0].tolist() == [1]
    assert average_precision(m) == 1.0


def test_the_threshold_is_chosen_without_ignored_detections() -> None:
    # the ignored detections score highest: counted as false alarms they would drag the best F1 below them
    found = _found((40, 40, 50, 50, 0.99), (40, 41, 50, 51, 0.98), (0, 0, 10, 10, 0.5), (80, 0, 90, 10, 0.4))
    m = match(found, [TRUTH], IGNORE)
    assert best_threshold(m) == pytest.approx(0.4)
    assert precision_at(m, 0.4) == 1.0 and recall_of(m, 0.4) == 1.0


def test_ignore_flags_must_name_every_true_box() -> None:
    with pytest.raises(ValueError, match="frame 0: 2 ignore flags for 3 true boxes"):
        match(_found((0, 0, 10, 10, 0.9)), [TRUTH], [np.array([False, True])])


def test_training_targets_neither_teach_nor_punish_an_ignored_person() -> None:
    boxes = np.array([[8.0, 8.0, 24.0, 16.0], [40.0, 40.0, 56.0, 48.0]], np.float32)
    t = targets(boxes, np.array([0.9, 0.3], np.float32), size=64, stride=4)
    assert int(t.mask.sum()) == 1 and t.mask[3, 4] == 1 and t.heat[3, 4] == 1.0
    assert t.heat[11, 12] < 1e-3 and t.mask[11, 12] == 0  # the ignored one: no positive ...
    assert (t.weight[10:13, 11:14] == 0).all()  # ... and no penalty for finding it
    assert t.weight[3, 4] == 1.0 and t.weight[0, 15] == 1.0


def test_neighbour_boxes_teach_the_two_nearest_cells_the_same_box_unless_another_person_is_centred_there() -> None:
    """A crowd's score peak lands a cell off the centre; with ``neighbour_boxes`` the box is taught there too: at
    the cell across and the cell down or up nearest the centre, each decoding (offset within the decoder's −0.5 to
    1.5) to the same centre and size; a cell that is another person's centre keeps that person's box."""
    stride = 4
    one = np.array([[8.0, 14.0, 24.0, 20.0]], np.float32)  # centre (16, 17): cell (4, 4), at 0.0 across, 0.25 down
    seen = np.array([0.9], np.float32)
    plain = targets(one, seen, size=64, stride=stride)
    t = targets(one, seen, size=64, stride=stride, neighbour_boxes=True)
    assert int(plain.mask.sum()) == 1
    cells = {(int(y), int(x)) for y, x in zip(*np.nonzero(t.mask), strict=True)}
    assert cells == {(4, 4), (4, 3), (3, 4)}  # the centre, the cell to its left, the cell above it
    for y, x in cells:
        dx, dy, log_w, log_h = (float(v) for v in t.reg[:, y, x])
        assert -0.5 <= dx < 1.5 and -0.5 <= dy < 1.5
        assert ((x + dx) * stride, (y + dy) * stride) == (16.0, 17.0)
        assert (np.exp(log_w) * stride, np.exp(log_h) * stride) == pytest.approx((16.0, 6.0))
        assert [float(v) for v in t.box[:, y, x]] == [8.0, 14.0, 24.0, 20.0]
    assert (t.heat == plain.heat).all() and (t.weight == plain.weight).all()  # the score's targets unchanged
    # a second person centred in the first one's left neighbour keeps that cell
    two = np.array([[8.0, 14.0, 24.0, 20.0], [10.0, 16.0, 18.0, 20.0]], np.float32)  # centre (14, 18): cell (3, 4)
    t2 = targets(two, np.array([0.9, 0.9], np.float32), size=64, stride=stride, neighbour_boxes=True)
    assert [float(v) for v in t2.box[:, 4, 3]] == [10.0, 16.0, 18.0, 20.0]
    assert [float(v) for v in t2.box[:, 4, 4]] == [8.0, 14.0, 24.0, 20.0]


def test_the_report_says_how_the_box_was_taught() -> None:
    """A recipe trained with ``--neighbour-boxes`` says so in the report's training line; one without does not."""
    from evaluation.detector.report import _training_line

    recipe: dict[str, Any] = {"config": {"data_seed": 1, "frames": 2, "neighbour_boxes": True}, "training": {}}
    assert "two cells beside each centre cell" in _training_line(recipe)
    recipe["config"]["neighbour_boxes"] = False
    assert "beside each centre" not in _training_line(recipe)


def _targets_one_by_one(boxes: np.ndarray, visible: np.ndarray, size: int, stride: int, neighbour: bool) -> Any:
    """The targets as a loop over persons writes them, the definition :func:`targets` computes in arrays."""
    import math

    grid = size // stride
    heat, weight = np.zeros((grid, grid)), np.ones((grid, grid))
    reg, box, mask = np.zeros((4, grid, grid)), np.zeros((4, grid, grid)), np.zeros((grid, grid), np.uint8)
    ys, xs = np.mgrid[0:grid, 0:grid]
    placed = []
    for (x0, y0, x1, y1), seen in zip(boxes.tolist(), visible.tolist(), strict=True):
        w, h = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
        cx, cy = (x0 + x1) / 2 / stride, (y0 + y1) / 2 / stride
        gx, gy = min(max(int(cx), 0), grid - 1), min(max(int(cy), 0), grid - 1)
        if seen < MIN_SEEN:
            weight[max(gy - 1, 0) : gy + 2, max(gx - 1, 0) : gx + 2] = 0.0
            continue
        sigma = max(0.5, 0.1 * math.sqrt(w * h) / stride)
        heat = np.maximum(heat, np.exp(-((xs - gx) ** 2 + (ys - gy) ** 2) / (2 * sigma * sigma)))
        reg[:, gy, gx] = (cx - gx, cy - gy, math.log(w / stride), math.log(h / stride))
        box[:, gy, gx], mask[gy, gx] = (x0, y0, x1, y1), 1
        placed.append(((x0, y0, x1, y1), cx, cy, gx, gy, w, h))
    for corners, cx, cy, gx, gy, w, h in placed if neighbour else []:
        for nx, ny in ((gx - 1 if cx - gx < 0.5 else gx + 1, gy), (gx, gy - 1 if cy - gy < 0.5 else gy + 1)):
            if 0 <= nx < grid and 0 <= ny < grid and not mask[ny, nx]:
                reg[:, ny, nx] = (cx - nx, cy - ny, math.log(w / stride), math.log(h / stride))
                box[:, ny, nx], mask[ny, nx] = corners, 1
    weight[heat >= 1.0] = 1.0
    return heat, weight, reg, box, mask


@pytest.mark.parametrize("neighbour", [False, True])
def test_the_targets_in_arrays_are_those_of_a_loop_over_persons_in_crowds(neighbour: bool) -> None:
    """Crowded crops (up to 150 persons, many sharing a cell, some outside the crop, some hardly seen): every
    target as the loop writes it; the score bumps, drawn only where above 1e-7 and in float32, to 3e-7."""
    rng = np.random.default_rng(7)
    for k in range(300):
        n = int(rng.integers(0, 150))
        centres, sizes = rng.uniform(-10, 106, (n, 2)), rng.uniform(0.5, 60, (n, 2))
        if k % 2 and n:
            centres[: n // 2] = np.round(centres[: n // 2] / 4) * 4 + 1  # half of them on a few shared cells
        boxes = np.concatenate([centres - sizes / 2, centres + sizes / 2], 1).astype(np.float32)
        visible = rng.uniform(0, 1, n).astype(np.float32)
        t = targets(boxes, visible, size=96, stride=4, neighbour_boxes=neighbour)
        heat, weight, reg, box, mask = _targets_one_by_one(boxes, visible, 96, 4, neighbour)
        assert np.abs(t.heat - heat).max() < 3e-7  # float32 against float64: a few units in the last place
        assert np.array_equal(t.weight, weight) and np.array_equal(t.mask, mask)
        assert np.allclose(t.reg, reg, atol=1e-6) and np.allclose(t.box, box, atol=1e-4)
