"""Detect time per frame: our shipped person detector (``--detector ours``: letterbox, ONNX Runtime on one thread,
decoding, non-maximum suppression) on rendered 640×480 frames, mean and 95th percentile. The frames are rendered
first and not timed (``benchmarks/perception.py`` times rendering). ``benchmarks/perception.py --detect N`` prints
this section."""

from __future__ import annotations

import time

import numpy as np


def detect_times(frames: int = 30, seed: int = 3) -> list[float]:
    """Seconds per detect on ``frames`` rendered frames (altitudes 10–60 m), after one untimed warm-up."""
    from agentic_core.perception.detectors.ours import load_ours
    from flight.sim.render.dataset import labelled_frames

    detector = load_ours()
    images = [f.image for f in labelled_frames(seed, frames)]
    detector.detect_array(images[0])
    out = []
    for image in images:
        start = time.perf_counter()
        detector.detect_array(image)
        out.append(time.perf_counter() - start)
    return out


def detect_section(frames: int) -> str:
    """The benchmark's lines for the detector."""
    times = np.array(detect_times(frames)) * 1e3
    return (
        f"detect (ours, 640x480, 1 thread): {len(times)} frames, mean {times.mean():.1f} ms, "
        f"p95 {np.percentile(times, 95):.1f} ms per frame"
    )


__all__ = ["detect_section", "detect_times"]
