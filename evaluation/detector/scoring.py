"""Scoring detections against exact labels: greedy matching at IoU ≥ 0.5, precision and recall at a threshold, and
average precision (all-point interpolation, as PASCAL VOC since 2010), over any subset of the true boxes.

A detection matched to a person outside the subset (a standing person, when scoring lying ones) is neither a hit
nor a false alarm for the subset's recall; precision always counts every detection against every person.

Persons barely seen (``ignore``: mostly covered by others or out of the image) are *ignored*, as KITTI's
"don't care" and COCO's crowd boxes: never a person to find (not in any recall), and a detection that matches one
of them and no counted person is neither a hit nor a false alarm (``Matched.ignored``: left out of precision and AP).

>>> import numpy as np
>>> truth = [np.array([[0, 0, 10, 10], [20, 20, 30, 30]], np.float32)]
>>> found = [(np.array([[0, 0, 10, 10], [50, 50, 60, 60]], np.float32), np.array([0.9, 0.8], np.float32))]
>>> m = match(found, truth)
>>> m.hit.tolist(), m.truth_hit[0].tolist()
([True, False], [True, False])
>>> round(average_precision(m), 3), precision_recall(m, 0.5)
(0.5, (0.5, 0.5))
>>> precision_recall(match([(truth[0], np.array([0.9, 0.8], np.float32))], truth, [np.array([False, True])]), 0.5)
(1.0, 1.0)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agentic_core.perception.calibration import long_sides
from agentic_core.perception.detectors.yolo_decode import iou

IOU_MATCH = 0.5
Masks = Sequence[NDArray[np.bool_]]


@dataclass(frozen=True)
class Matched:
    """All frames' detections, best first within each frame, and which true box (if any) each one hit."""

    scores: NDArray[np.float64]
    hit: NDArray[np.bool_]
    """Matched to a counted true person."""
    ignored: NDArray[np.bool_]
    """Matched no counted person but an ignored one: neither a hit nor a false alarm."""
    truth_index: list[NDArray[np.int64]]
    """Per frame, for each detection, the index of the counted true box it matched (-1 none)."""
    truth_hit: list[NDArray[np.bool_]]
    """Per frame, for each true box, whether a detection above 0 matched it (for recall at any threshold, use
    :func:`recall_of`)."""
    truth_score: list[NDArray[np.float64]]
    """Per frame, for each true box, the score of the detection that matched it (0 when none, and for ignored)."""
    counted: list[NDArray[np.bool_]]
    """Per frame, which true boxes count (not ignored)."""
    frames: int
    long_px: NDArray[np.float64]
    """Each detection's box's longer side in pixels, in the order of ``scores`` (what a size-aware calibration
    reads)."""

    def counted_detections(self, threshold: float) -> NDArray[np.bool_]:
        """The detections scoring at least ``threshold`` that precision counts (all but the ignored)."""
        kept: NDArray[np.bool_] = (self.scores >= threshold) & ~self.ignored
        return kept


def match(
    detections: Sequence[tuple[NDArray[np.float32], NDArray[np.float32]]],
    truth: Sequence[NDArray[np.float32]],
    ignore: Masks | None = None,
) -> Matched:
    """Match each frame's detections (boxes, scores) to its true boxes, best score first, each counted true box
    once; ``ignore`` (per frame, per true box) names the ignored persons."""
    scores: list[float] = []
    long_px: list[float] = []
    hits: list[bool] = []
    ignored: list[bool] = []
    indices: list[NDArray[np.int64]] = []
    truth_hit: list[NDArray[np.bool_]] = []
    truth_score: list[NDArray[np.float64]] = []
    counted_all: list[NDArray[np.bool_]] = []
    for k, ((boxes, conf), true_boxes) in enumerate(zip(detections, truth, strict=True)):
        skip = np.zeros(len(true_boxes), bool) if ignore is None else np.asarray(ignore[k], bool)
        if len(skip) != len(true_boxes):
            raise ValueError(f"frame {k}: {len(skip)} ignore flags for {len(true_boxes)} true boxes")
        order = np.argsort(-conf, kind="stable")
        long_px.extend(long_sides(boxes)[order].tolist())
        taken = np.zeros(len(true_boxes), bool)
        best = np.zeros(len(true_boxes), np.float64)
        index = np.full(len(boxes), -1, np.int64)
        for i in order:
            dont_care = False
            if len(true_boxes):
                overlap = iou(boxes[i], true_boxes)
                dont_care = bool(np.any(overlap[skip] >= IOU_MATCH))
                overlap[taken | skip] = -1.0
                j = int(np.argmax(overlap))
                if overlap[j] >= IOU_MATCH:
                    taken[j] = True
                    best[j] = float(conf[i])
                    index[i] = j
            scores.append(float(conf[i]))
            hits.append(bool(index[i] >= 0))
            ignored.append(bool(index[i] < 0 and dont_care))
        indices.append(index[order])
        truth_hit.append(taken)
        truth_score.append(best)
        counted_all.append(~skip)
    return Matched(
        np.array(scores), np.array(hits, bool), np.array(ignored, bool), indices, truth_hit, truth_score,
        counted_all, len(truth), np.array(long_px, np.float64),
    )  # fmt: skip


def recall_of(m: Matched, threshold: float, subset: Masks | None = None) -> float:
    """The share of counted true boxes (of ``subset``, per frame masks) found by a detection scoring at least
    ``threshold``."""
    found = total = 0
    for k, score in enumerate(m.truth_score):
        chosen = m.counted[k] if subset is None else subset[k] & m.counted[k]
        found += int(np.sum(score[chosen] >= max(threshold, 1e-12)))
        total += int(np.sum(chosen))
    return found / total if total else float("nan")


def precision_at(m: Matched, threshold: float) -> float:
    """The share of hits among the detections scoring at least ``threshold`` (ignored ones left out)."""
    kept = m.counted_detections(threshold)
    return float(np.mean(m.hit[kept])) if kept.any() else float("nan")


def precision_recall(m: Matched, threshold: float) -> tuple[float, float]:
    """Precision and recall (of all counted true boxes) counting detections scoring at least ``threshold``."""
    return precision_at(m, threshold), recall_of(m, threshold)


def average_precision(m: Matched, subset: Masks | None = None) -> float:
    """AP at IoU 0.5: the area under the interpolated precision–recall curve. With ``subset``, recall counts only
    those true boxes and detections matched outside it are left out; ignored detections are always left out."""
    keep = ~m.ignored
    positives = sum(int(np.sum(c)) for c in m.counted)
    if subset is not None:
        pairs = zip(m.truth_index, subset, strict=True)
        inside = np.concatenate([np.isin(idx, np.flatnonzero(sub)) for idx, sub in pairs] or [np.zeros(0, bool)])
        keep &= ~m.hit | inside
        positives = int(sum(int(np.sum(s & c)) for s, c in zip(subset, m.counted, strict=True)))
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


__all__ = ["IOU_MATCH", "Matched", "average_precision", "match", "precision_at", "precision_recall", "recall_of"]
