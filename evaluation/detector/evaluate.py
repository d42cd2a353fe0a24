"""The person detector on held-out renders: run it on labelled frames, then precision, recall and AP@0.5 over
all persons and by pose. A detection counts as a hit when it matches any person (IoU ≥ 0.5); a pose's recall is
the share of that pose's persons found. Persons seen less than half (``visible`` < :data:`MIN_SEEN`: under other
persons or mostly out of the image) are ignored, neither to be found nor a false alarm when found
(:mod:`evaluation.detector.scoring`).

>>> import numpy as np
>>> from evaluation.detector.scoring import match
>>> boxes = [np.array([[0, 0, 10, 10], [20, 20, 30, 30]], np.float32)]
>>> m = match([(boxes[0][:1], np.array([0.9], np.float32))], boxes)
>>> s = scores_at(m, 0.5, [np.array([True, False])])
>>> s.precision, s.recall, s.truth
(1.0, 1.0, 1)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraSpec
from agentic_core.perception.detectors import OnnxDetector
from flight.sim.render.dataset import HFOV_DEG, MIN_SEEN

from .scoring import Matched, average_precision, match, precision_at, recall_of
from .train import Labelled

POSES = ("standing", "walking", "sitting", "lying")
CALIBRATION_SEED = 2
"""Renders the calibration and the operating threshold are fitted on (training uses seed 1)."""
TEST_SEED = 3
"""Held-out renders for the report and the acceptance test: scenes neither training nor calibration saw."""
TEST_FRAMES = 30
"""Held-out frames per altitude."""
FLOOR = 0.02
"""Raw scores kept for the precision-recall curve (far below any operating threshold)."""


@dataclass(frozen=True)
class Scores:
    """Precision (of every detection at the threshold), recall and AP@0.5 (of the chosen persons), how many."""

    precision: float
    recall: float
    ap50: float
    truth: int


def detect_all(
    detector: OnnxDetector, frames: Sequence[Labelled]
) -> list[tuple[NDArray[np.float32], NDArray[np.float32]]]:
    """The detector's boxes and raw scores on each frame, looked at twice where a run would (a close frame)."""
    out = []
    for index, frame in enumerate(frames):
        twice = detector.looks_twice(render_focal_px(frame.image.shape[1]), frame.altitude_m)
        boxes, scores, _ = detector.detect_array(frame.image, twice=twice, index=index)
        out.append((boxes, scores))
    return out


def render_focal_px(width_px: int) -> float:
    """The focal length (pixels) of the renders' camera at ``width_px``: what a run's camera tells the detector."""
    return CameraSpec(width_px=width_px, hfov_deg=HFOV_DEG).focal_px


def evaluate(detector: OnnxDetector, frames: Sequence[Labelled]) -> Matched:
    """Run ``detector`` on ``frames`` and match its detections to their labels (the barely seen ignored)."""
    return match(detect_all(detector, frames), [f.boxes for f in frames], ignored(frames))


def ignored(frames: Sequence[Labelled]) -> list[NDArray[np.bool_]]:
    """Per frame, which labels are ignored: persons seen less than :data:`MIN_SEEN`."""
    return [np.asarray(f.visible < MIN_SEEN, bool) for f in frames]


def pose_masks(frames: Sequence[Labelled], pose: str | None) -> list[NDArray[np.bool_]]:
    """Per frame, which labels have ``pose`` (all of them for None)."""
    return [np.array([p == pose or pose is None for p in f.poses], bool) for f in frames]


def scores_at(m: Matched, threshold: float, subset: Sequence[NDArray[np.bool_]]) -> Scores:
    """Precision of all detections scoring ≥ ``threshold``; recall and AP of the ``subset`` persons."""
    truth = int(sum(int(np.sum(s & c)) for s, c in zip(subset, m.counted, strict=True)))
    return Scores(precision_at(m, threshold), recall_of(m, threshold, subset), average_precision(m, subset), truth)


def best_threshold(m: Matched) -> float:
    """The raw score threshold with the best F1 over all counted persons (chosen on calibration renders, never the
    test)."""
    order = np.argsort(-m.scores, kind="stable")
    order = order[~m.ignored[order]]
    hits = m.hit[order]
    positives = sum(int(np.sum(c)) for c in m.counted)
    tp = np.cumsum(hits)
    precision = tp / np.arange(1, len(hits) + 1)
    recall = tp / max(positives, 1)
    f1 = 2 * precision * recall / np.maximum(precision + recall, 1e-12)
    if not len(f1):
        return 0.5
    return float(m.scores[order][int(np.argmax(f1))])


__all__ = [
    "CALIBRATION_SEED",
    "POSES",
    "TEST_FRAMES",
    "TEST_SEED",
    "Scores",
    "best_threshold",
    "detect_all",
    "evaluate",
    "ignored",
    "pose_masks",
    "render_focal_px",
    "scores_at",
]
