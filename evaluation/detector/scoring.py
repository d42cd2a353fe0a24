"""Scoring detections against exact labels: greedy matching at IoU ≥ 0.5, precision and recall at a threshold, and
average precision (all-point interpolation, as PASCAL VOC since 2010), over any subset of the true boxes.

A detection matched to a person outside the subset (a standing person, when scoring lying ones) is neither a hit
nor a false alarm for the subset's recall; precision always counts every detection against every person.

>>> import numpy as np
>>> truth = [np.array([[0, 0, 10, 10], [20, 20, 30, 30]], np.float32)]
>>> found = [(np.array([[0, 0, 10, 10], [50, 50, 60, 60]], np.float32), np.array([0.9, 0.8], np.float32))]
>>> m = match(found, truth)
>>> m.hit.tolist(), m.truth_hit[0].tolist()
([True, False], [True, False])
>>> round(average_precision(m), 3), precision_recall(m, 0.5)
(0.5, (0.5, 0.5))
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agentic_core.perception.detectors.yolo_decode import iou

IOU_MATCH = 0.5


@dataclass(frozen=True)
class Matched:
    """All frames' detections, best first within each frame, and which true box (if any) each one hit."""

    scores: NDArray[np.float64]
    hit: NDArray[np.bool_]
    """Matched to a true person."""
    truth_index: list[NDArray[np.int64]]
    """Per frame, for each detection, the index of the true box it matched (-1 none)."""
    truth_hit: list[NDArray[np.bool_]]
    """Per frame, for each true box, whether a detection above 0 matched it (for recall at any threshold, use
    :func:`recall_of`)."""
    truth_score: list[NDArray[np.float64]]
    """Per frame, for each true box, the score of the detection that matched it (0 when none)."""
    frames: int


def match(
    detections: Sequence[tuple[NDArray[np.float32], NDArray[np.float32]]], truth: Sequence[NDArray[np.float32]]
) -> Matched:
    """Match each frame's detections (boxes, scores) to its true boxes, best score first, each true box once."""
    scores: list[float] = []
    hits: list[bool] = []
    indices: list[NDArray[np.int64]] = []
    truth_hit: list[NDArray[np.bool_]] = []
    truth_score: list[NDArray[np.float64]] = []
    for (boxes, conf), true_boxes in zip(detections, truth, strict=True):
        order = np.argsort(-conf, kind="stable")
        taken = np.zeros(len(true_boxes), bool)
        best = np.zeros(len(true_boxes), np.float64)
        index = np.full(len(boxes), -1, np.int64)
        for i in order:
            if len(true_boxes):
                overlap = iou(boxes[i], true_boxes)
                overlap[taken] = -1.0
                j = int(np.argmax(overlap))
                if overlap[j] >= IOU_MATCH:
                    taken[j] = True
                    best[j] = float(conf[i])
                    index[i] = j
            scores.append(float(conf[i]))
            hits.append(bool(index[i] >= 0))
        indices.append(index[order])
        truth_hit.append(taken)
        truth_score.append(best)
    return Matched(np.array(scores), np.array(hits, bool), indices, truth_hit, truth_score, len(truth))


def recall_of(m: Matched, threshold: float, subset: Sequence[NDArray[np.bool_]] | None = None) -> float:
    """The share of true boxes (of ``subset``, per frame masks) found by a detection scoring at least ``threshold``."""
    found = total = 0
    for k, score in enumerate(m.truth_score):
        chosen = np.ones(len(score), bool) if subset is None else subset[k]
        found += int(np.sum(score[chosen] >= max(threshold, 1e-12)))
        total += int(np.sum(chosen))
    return found / total if total else float("nan")


def precision_recall(m: Matched, threshold: float) -> tuple[float, float]:
    """Precision and recall (of all true boxes) counting detections scoring at least ``threshold``."""
    kept = m.scores >= threshold
    precision = float(np.mean(m.hit[kept])) if kept.any() else float("nan")
    return precision, recall_of(m, threshold)


def average_precision(m: Matched, subset: Sequence[NDArray[np.bool_]] | None = None) -> float:
    """AP at IoU 0.5: the area under the interpolated precision–recall curve. With ``subset``, recall counts only
    those true boxes and detections matched outside it are left out."""
    keep = np.ones(len(m.scores), bool)
    positives = sum(len(s) for s in m.truth_score)
    if subset is not None:
        pairs = zip(m.truth_index, subset, strict=True)
        inside = np.concatenate([np.isin(idx, np.flatnonzero(sub)) for idx, sub in pairs] or [np.zeros(0, bool)])
        keep = ~m.hit | inside
        positives = int(sum(int(np.sum(s)) for s in subset))
    if positives == 0:
        return float("nan")
    order = np.argsort(-m.scores[keep], kind="stable")
    hits = m.hit[keep][order]
    tp = np.cumsum(hits)
    fp = np.cumsum(~hits)
    recall = tp / positives
    precision = tp / np.maximum(tp + fp, 1)
    envelope = np.maximum.accumulate(np.r_[precision, 0.0][::-1])[::-1]
    steps = np.diff(np.r_[0.0, recall])
    return float(np.sum(steps * envelope[: len(steps)]))


__all__ = ["IOU_MATCH", "Matched", "average_precision", "match", "precision_recall", "recall_of"]
