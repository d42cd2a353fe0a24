"""Non-maximum suppression holds its two promises on any boxes: no two kept boxes of a class overlap by more than
the threshold, and every dropped box overlaps a kept, better one of its class by more than it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.perception.detectors.suppression import greedy_nms, iou_matrix
from agentic_core.perception.detectors.yolo_decode import iou, nms

box = st.tuples(st.floats(0, 100), st.floats(0, 100), st.floats(0.5, 40), st.floats(0.5, 40))


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(box, st.floats(0, 1), st.integers(0, 2)), max_size=30), st.floats(0.05, 0.95))
def test_nms_keeps_no_overlap_and_drops_only_overlapped(items, threshold: float) -> None:
    boxes = np.array([[x, y, x + w, y + h] for (x, y, w, h), _, _ in items], float).reshape(-1, 4)
    scores = np.array([s for _, s, _ in items], float)
    classes = np.array([c for _, _, c in items], np.int64)
    kept = nms(boxes, scores, threshold, classes)
    assert len(set(kept)) == len(kept) and all(0 <= k < len(items) for k in kept)
    assert [scores[k] for k in kept] == sorted((scores[k] for k in kept), reverse=True)
    for i, a in enumerate(kept):
        for b in kept[i + 1 :]:
            if classes[a] == classes[b]:
                assert iou(boxes[a], boxes[b : b + 1])[0] <= threshold + 1e-9
    for d in set(range(len(items))) - set(kept):
        rivals = [k for k in kept if classes[k] == classes[d] and scores[k] >= scores[d]]
        assert rivals and max(iou(boxes[d], boxes[rivals])) > threshold - 1e-9


def test_nms_of_nothing() -> None:
    assert nms(np.zeros((0, 4)), np.zeros(0), 0.5) == []


crowded = st.tuples(st.floats(0, 60), st.floats(0, 60), st.floats(0.0, 25), st.floats(0.0, 25))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(st.tuples(crowded, st.sampled_from([0.1, 0.5, 0.5, 0.9]) | st.floats(0, 1), st.integers(0, 1)),
             max_size=60),
    st.floats(-0.2, 1.0),
    st.integers(-1, 70),
    st.booleans(),
)  # fmt: skip
def test_nms_is_exactly_the_textbook_loop(items, threshold: float, max_keep: int, by_class: bool) -> None:
    """Crowded boxes (tied scores, zero-size and identical boxes, thresholds at and below 0, caps): the pairs-only
    suppression keeps exactly what the loop over every box keeps, in the same order."""
    boxes = np.array([[x, y, x + w, y + h] for (x, y, w, h), _, _ in items], float).reshape(-1, 4)
    scores = np.array([s for _, s, _ in items], float)
    classes = np.array([c for _, _, c in items], np.int64) if by_class else None
    assert nms(boxes, scores, threshold, classes, max_keep) == greedy_nms(boxes, scores, threshold, classes, max_keep)


def test_nms_of_a_real_crowd_frame_is_the_textbook_loops() -> None:
    """A frame's worth of candidates (600 boxes of persons 5–25 px in a 640×480 frame, many overlapping): the same
    300 kept, and a box that is not finite sends the call to the loop itself."""
    rng = np.random.default_rng(5)
    corner = rng.uniform(0, [640, 480], (600, 2))
    boxes = np.column_stack([corner, corner + rng.uniform(5, 25, (600, 2))])
    scores = rng.random(600)
    assert nms(boxes, scores, 0.45) == greedy_nms(boxes, scores, 0.45)
    boxes[7, 2] = np.nan
    assert nms(boxes, scores, 0.45) == greedy_nms(boxes, scores, 0.45)


@settings(max_examples=100, deadline=None)
@given(st.lists(crowded, max_size=15), st.lists(crowded, max_size=15))
def test_the_iou_matrix_is_each_pairs_iou(a, b) -> None:
    first = np.array([[x, y, x + w, y + h] for x, y, w, h in a], float).reshape(-1, 4)
    second = np.array([[x, y, x + w, y + h] for x, y, w, h in b], float).reshape(-1, 4)
    matrix = iou_matrix(first, second)
    assert matrix.shape == (len(a), len(b))
    for i, box in enumerate(first):
        assert matrix[i].tolist() == iou(box, second).tolist()
