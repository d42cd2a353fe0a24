"""Greedy non-maximum suppression that looks only at boxes that can overlap.

Why: a crowd frame gives hundreds of candidates, and the textbook loop (take the best, drop what overlaps it,
repeat) computes each kept box's overlap with every box left: about 7 ms a frame for our detector, a quarter of its
time. Boxes that overlap have centres no farther apart than the largest box's diagonal, so a k-d tree finds the
few pairs worth an intersection-over-union, and the greedy pass then walks only the boxes that overlap a worse one
too much, best first (in a crowd, a few of hundreds), leaving the rest kept in score order. The result is exactly the
textbook loop's (:func:`greedy_nms`, kept as the reference and for boxes that are not finite): same boxes kept, in
the same order, the same arithmetic deciding each overlap.

>>> import numpy as np
>>> boxes = np.array([[0, 0, 10, 10], [1, 1, 11, 11], [50, 50, 60, 60], [52, 50, 62, 60]], float)
>>> nms(boxes, np.array([0.9, 0.8, 0.7, 0.95]), 0.5), greedy_nms(boxes, np.array([0.9, 0.8, 0.7, 0.95]), 0.5)
([3, 0], [3, 0])
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree


def iou(box: NDArray[np.floating], boxes: NDArray[np.floating]) -> NDArray[np.float64]:
    """Intersection over union of one box with each of ``boxes`` (corner form)."""
    return _pairwise(np.broadcast_to(box, boxes.shape), boxes)


def iou_matrix(a: NDArray[np.floating], b: NDArray[np.floating]) -> NDArray[np.float64]:
    """Intersection over union of every box of ``a`` (N×4) with every box of ``b`` (M×4): N×M, each as :func:`iou`
    gives it."""
    left = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    right = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    return _pairwise(left[:, None, :], right[None, :, :])  # broadcast N×M, no N·M copies of either side


def _pairwise(a: NDArray[np.floating], b: NDArray[np.floating]) -> NDArray[np.float64]:
    """Intersection over union of ``a[..., k, :]`` with ``b[..., k, :]`` (corner form), broadcast as numpy does."""
    x0 = np.maximum(a[..., 0], b[..., 0])
    y0 = np.maximum(a[..., 1], b[..., 1])
    x1 = np.minimum(a[..., 2], b[..., 2])
    y1 = np.minimum(a[..., 3], b[..., 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    union = (
        (a[..., 2] - a[..., 0]) * (a[..., 3] - a[..., 1]) + (b[..., 2] - b[..., 0]) * (b[..., 3] - b[..., 1]) - inter
    )
    return np.where(union > 0, inter / np.where(union > 0, union, 1.0), 0.0).astype(np.float64)


def _prepared(
    boxes: NDArray[np.floating], scores: NDArray[np.floating], classes: NDArray[np.int64] | None
) -> tuple[NDArray[np.float64], NDArray[np.intp]]:
    """The boxes as float64, each class moved out of every other's way, and the order best score first."""
    work = boxes.astype(np.float64)
    if classes is not None:
        span = float(np.max(work[:, 2:]) - np.min(work[:, :2])) + 1.0
        work = work + (classes.astype(np.float64) * span)[:, None]
    return work, np.argsort(-scores, kind="stable")


def greedy_nms(
    boxes: NDArray[np.floating],
    scores: NDArray[np.floating],
    iou_threshold: float,
    classes: NDArray[np.int64] | None = None,
    max_keep: int = 300,
) -> list[int]:
    """The textbook loop: indices kept, best score first; a box is dropped when it overlaps a kept one of the same
    class (all one class when ``classes`` is None) by more than ``iou_threshold``."""
    if len(boxes) == 0:
        return []
    work, order = _prepared(boxes, scores, classes)
    keep: list[int] = []
    while order.size and len(keep) < max_keep:
        best = int(order[0])
        keep.append(best)
        rest = order[1:]
        order = rest[iou(work[best], work[rest]) <= iou_threshold]
    return keep


def nms(
    boxes: NDArray[np.floating],
    scores: NDArray[np.floating],
    iou_threshold: float,
    classes: NDArray[np.int64] | None = None,
    max_keep: int = 300,
) -> list[int]:
    """:func:`greedy_nms`'s answer, from the pairs of boxes that can overlap only."""
    if len(boxes) == 0:
        return []
    work, order = _prepared(boxes, scores, classes)
    if not np.isfinite(work).all() or iou_threshold < 0.0:  # below 0 even boxes apart are "over": every pair counts
        return greedy_nms(boxes, scores, iou_threshold, classes, max_keep)
    centres = (work[:, :2] + work[:, 2:]) / 2.0
    reach = float(np.hypot(work[:, 2] - work[:, 0], work[:, 3] - work[:, 1]).max())
    pairs = cKDTree(centres).query_pairs(reach * (1.0 + 1e-9) + 1e-9, output_type="ndarray")
    rank = np.empty(len(work), dtype=np.intp)
    rank[order] = np.arange(len(work))
    a, b = pairs[:, 0], pairs[:, 1]
    first = np.where(rank[a] < rank[b], a, b)  # the better of each pair: it may drop the other
    second = np.where(rank[a] < rank[b], b, a)
    over = _pairwise(work[first], work[second]) > iou_threshold
    first, second = first[over], second[over]
    by_first = np.argsort(first, kind="stable")
    starts = np.searchsorted(first[by_first], np.arange(len(work) + 1))
    beaten = second[by_first]
    dropped = np.zeros(len(work), dtype=bool)
    # Only boxes that beat another can drop one, and a box's fate rests on better boxes alone: walk those few best
    # first, and what is left, best first, is what the loop over every box keeps (the cap cuts after the drops,
    # which only ever reach worse boxes).
    droppers = np.unique(first)
    for best in droppers[np.argsort(rank[droppers])].tolist():
        if not dropped[best]:
            dropped[beaten[starts[best] : starts[best + 1]]] = True
    keep: list[int] = order[~dropped[order]][: max(max_keep, 0)].tolist()
    return keep


__all__ = ["greedy_nms", "iou", "iou_matrix", "nms"]
