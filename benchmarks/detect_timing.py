"""Detect time per frame: our shipped person detector (``--detector ours``: letterbox, ONNX Runtime on one thread,
decoding, non-maximum suppression) on rendered 640×480 frames, mean and 95th percentile of the wall clock, and the
mean CPU time of this process (on a shared machine the wall clock also counts waiting for a core). The frames are
rendered first and not timed (``benchmarks/perception.py`` times rendering). ``benchmarks/perception.py --detect N``
prints this section."""

from __future__ import annotations

import time

import numpy as np


def detect_times(frames: int = 30, seed: int = 3) -> list[tuple[float, float]]:
    """Wall and CPU seconds per detect on ``frames`` rendered frames (altitudes 10–60 m), after one untimed
    warm-up."""
    from agentic_core.perception.detectors.ours import load_ours
    from flight.sim.render.dataset import labelled_frames

    detector = load_ours()
    images = [f.image for f in labelled_frames(seed, frames)]
    detector.detect_array(images[0])
    out = []
    for image in images:
        start, cpu = time.perf_counter(), time.process_time()
        detector.detect_array(image)
        out.append((time.perf_counter() - start, time.process_time() - cpu))
    return out


def detect_section(frames: int) -> str:
    """The benchmark's lines for the detector."""
    times = np.array(detect_times(frames)) * 1e3
    wall, cpu = times[:, 0], times[:, 1]
    return (
        f"detect (ours, 640x480, 1 thread): {len(times)} frames, mean {wall.mean():.1f} ms, "
        f"p95 {np.percentile(wall, 95):.1f} ms, cpu {cpu.mean():.1f} ms per frame"
    )


__all__ = ["detect_section", "detect_times"]
