"""Non-maximum suppression holds its two promises on any boxes: no two kept boxes of a class overlap by more than
the threshold, and every dropped box overlaps a kept, better one of its class by more than it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

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
