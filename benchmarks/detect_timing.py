"""Detect time per frame: our shipped person detector (``--detector ours``: letterbox, ONNX Runtime on one thread,
decoding, non-maximum suppression) on rendered 640×480 frames, mean and 95th percentile of the wall clock, and the
mean CPU time of this process (on a shared machine the wall clock also counts waiting for a core); then the same
with the :class:`~agentic_core.contracts.camera.Detection` records a run gets (``detect(frame)``: calibrated, one
record a person). The frames are rendered first and not timed (``benchmarks/perception.py`` times rendering).
``benchmarks/perception.py --detect N`` prints this section."""

from __future__ import annotations

import time

import numpy as np


def detect_times(frames: int = 30, seed: int = 3) -> list[tuple[float, float, float]]:
    """Wall and CPU seconds per ``detect_array``, and wall seconds per ``detect`` (the records too), on ``frames``
    rendered frames (altitudes 10–60 m), after one untimed warm-up."""
    from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame
    from agentic_core.perception.detectors.ours import load_ours
    from flight.sim.render.dataset import labelled_frames

    detector = load_ours()
    images = [f.image for f in labelled_frames(seed, frames)]
    spec = CameraSpec(width_px=images[0].shape[1], height_px=images[0].shape[0])
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    detector.detect_array(images[0])
    out = []
    for k, image in enumerate(images):
        start, cpu = time.perf_counter(), time.process_time()
        detector.detect_array(image)
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
        frame = Frame(index=k, time_s=0.0, spec=spec, pose=pose, image=image)
        start = time.perf_counter()
        detector.detect(frame)
        out.append((wall, cpu, time.perf_counter() - start))
    return out


def detect_section(frames: int) -> str:
    """The benchmark's lines for the detector."""
    times = np.array(detect_times(frames)) * 1e3
    wall, cpu, records = times[:, 0], times[:, 1], times[:, 2]
    return (
        f"detect (ours, 640x480, 1 thread): {len(times)} frames, mean {wall.mean():.1f} ms, "
        f"p95 {np.percentile(wall, 95):.1f} ms, cpu {cpu.mean():.1f} ms per frame; "
        f"with the Detection records: mean {records.mean():.1f} ms"
    )


__all__ = ["detect_section", "detect_times"]
