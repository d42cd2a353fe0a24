"""The issue's Done-when, computed: the shipped person detector (``--detector ours``, through the same
``load_ours`` path a run takes, its recipe's threshold) on held-out renders at 30 m (seed 3: scenes neither
training, seed 1, nor calibration, seed 2, saw) finds at least 90 % of the lying persons, at a precision of at
least 90 % over all its detections (a hit: IoU ≥ 0.5 with a labelled person).

Persons seen less than half (``LabelledFrame.visible`` < ``MIN_SEEN``: under other persons, exactly from the
renderer's drawing order, or mostly out of the image) are ignored, as KITTI and COCO ignore heavily occluded and
crowd boxes: they are not among the lying persons to find, and a detection on one is neither a hit nor a false
alarm. Every other person counts; the scenes, the crowds and the IoU are the report's."""

from __future__ import annotations

import pytest

pytest.importorskip("onnxruntime")

from agentic_core.perception.detectors.ours import load_ours
from evaluation.detector.evaluate import TEST_FRAMES, TEST_SEED, detect_all, ignored, pose_masks
from evaluation.detector.scoring import match, precision_at, recall_of
from evaluation.detector.train import TrainConfig, render_frames


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason="the shipped detector misses the Done-when: at 30 m it finds 0.654 of the lying persons seen at least half, "
    "at precision 0.940 (docs/detector.md, which breaks down where the rest are lost); the threshold stays, and this "
    "marker goes when better weights pass",
)
def test_lying_persons_at_30_m_recall_and_precision_at_least_0_9() -> None:
    detector = load_ours()
    frames = render_frames(TrainConfig(altitudes_m=(30.0,)), seed=TEST_SEED, count=TEST_FRAMES)
    m = match(detect_all(detector, frames), [f.boxes for f in frames], ignored(frames))
    lying = pose_masks(frames, "lying")
    counted = sum(int((s & c).sum()) for s, c in zip(lying, m.counted, strict=True))
    assert counted >= 100, "too few lying persons to judge"
    precision = precision_at(m, detector.score_threshold)
    recall = recall_of(m, detector.score_threshold, lying)
    print(
        f"30 m, lying: recall {recall:.3f} of {counted}; precision (all detections) {precision:.3f}; "
        f"{len(m.scores)} detections, {int(m.ignored.sum())} on ignored persons"
    )
    assert recall >= 0.9 and precision >= 0.9, f"recall {recall:.3f}, precision {precision:.3f}"
