"""The issue's Done-when, computed: the shipped person detector (``--detector ours``, through the same
``load_ours`` path a run takes, its recipe's threshold) on held-out renders at 30 m (seed 3: scenes neither
training, seed 1, nor calibration, seed 2, saw) finds at least 90 % of the lying persons, at a precision of at
least 90 % over all its detections (a hit: IoU ≥ 0.5 with any labelled person)."""

from __future__ import annotations

import pytest

pytest.importorskip("onnxruntime")

from agentic_core.perception.detectors.ours import load_ours
from evaluation.detector.evaluate import TEST_FRAMES, TEST_SEED, detect_all, pose_masks
from evaluation.detector.scoring import match, recall_of
from evaluation.detector.train import TrainConfig, render_frames


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the shipped detector misses the Done-when: at 30 m it finds 0.257 of lying persons at precision 0.797 "
    "(docs/detector.md); the threshold stays, and this marker goes when better weights pass",
)
def test_lying_persons_at_30_m_recall_and_precision_at_least_0_9() -> None:
    detector = load_ours()
    frames = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=TEST_SEED, count=TEST_FRAMES)
    lying = pose_masks(frames, "lying")
    assert sum(int(m.sum()) for m in lying) >= 100, "too few lying persons to judge"
    m = match(detect_all(detector, frames), [f.boxes for f in frames])
    precision = float(m.hit.mean())
    recall = recall_of(m, detector.score_threshold, lying)
    print(f"30 m, lying: recall {recall:.3f}; precision (all detections) {precision:.3f}; {len(m.scores)} detections")
    assert recall >= 0.9 and precision >= 0.9, f"recall {recall:.3f}, precision {precision:.3f}"
