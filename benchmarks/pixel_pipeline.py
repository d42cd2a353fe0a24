"""The whole pixel pipeline, as a run flies it: the scene moved to the frame's time, the frame rendered, the detector
run on its pixels, each detection linked to the person it covers (for evaluation), then tracking, relations and
the World Model (``PerceptionLoop.observe``, the same call a run's camera makes on each telemetry sample).

The scene is ``render_timing.crowd_scene(N)``: a walkway of exactly N persons filling the view of a 640×480 camera
(84°, straight down) 30 m up, drifting north at 0.6 m/s. For each detector (``ours``, and ``sim`` for reference:
the statistical detector, no pixels) it times ``--frames`` observations after ``--warmup`` and reports the CPU
time of this process per frame (every thread: ONNX Runtime runs on one) and the split the loop records (sensing:
camera and detector; pipeline: tracker, relations, contract). ``ours`` is timed again at ``--close-m`` (15 m, the
emergency mission's close look), where it looks at each frame twice (``detectors/second_look.py``).

Target (issue 21): at 200 persons, at least 30 frames per CPU-second, so one core keeps up with a 30 Hz camera in
simulated time.

Usage: ``python benchmarks/pixel_pipeline.py [--sizes 50 200] [--frames 60] [--warmup 10]``.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from render_timing import crowd_scene  # noqa: E402  (beside this script)

from agentic_core.contracts.camera import CameraPose  # noqa: E402
from agentic_core.run.detector_choice import camera_spec  # noqa: E402
from agentic_core.run.perception_loop import PerceptionLoop  # noqa: E402
from flight.sim.detector import SimulatedCamera  # noqa: E402

TARGET_FPS = 30.0
TARGET_SIZE = 200
ALTITUDE_M = 30.0
CLOSE_M = 15.0


def run_once(n: int, detector: str, frames: int, warmup: int, altitude_m: float = ALTITUDE_M) -> dict[str, float]:
    """CPU and wall ms per observed frame, and the loop's own split, for one fresh loop."""
    loop = PerceptionLoop(crowd_scene(n), seed=n, camera=SimulatedCamera(camera_spec(detector)), detector=detector)
    period = loop.camera.spec.frame_period_s
    cpu: list[float] = []
    wall: list[float] = []
    sensing = pipeline = 0.0
    objects = 0
    for k in range(warmup + frames):
        t = k * period
        pose = CameraPose(north_m=0.6 * t - 1.0, east_m=0.0, down_m=-altitude_m)
        c, w = time.process_time(), time.perf_counter()
        world = loop.observe(pose, t)
        c, w = time.process_time() - c, time.perf_counter() - w
        if k >= warmup:
            cpu.append(c)
            wall.append(w)
            sensing += loop.last_sensor_s
            pipeline += loop.last_pipeline_s
            objects += len(world.objects)
    return {
        "cpu_ms": 1e3 * statistics.fmean(cpu),
        "wall_ms": 1e3 * statistics.fmean(wall),
        "sensing_ms": 1e3 * sensing / frames,
        "pipeline_ms": 1e3 * pipeline / frames,
        "objects": objects / frames,
    }


def table(sizes: list[int], frames: int, warmup: int, close_m: float = CLOSE_M) -> list[str]:
    """The benchmark's lines, with the verdict at the target size (at the patrol height)."""
    lines = [
        f"pixel pipeline benchmark (render, detect, link, track, relations, World Model; 640x480 at {ALTITUDE_M:g} m,"
        f" ours also at {close_m:g} m)",
        f"{frames} timed frames after {warmup} warm-up; ms per frame (cpu: this process, every thread)",
        f"{'detector':>9}{'height':>8}{'persons':>8}{'objects':>9}{'cpu':>9}{'wall':>9}{'sensing':>9}{'pipeline':>9}"
        f"{'fps/core':>10}",
    ]
    fps: dict[tuple[str, int], float] = {}
    for detector, height in (("ours", ALTITUDE_M), ("ours", close_m), ("sim", ALTITUDE_M)):
        for n in sizes:
            r = run_once(n, detector, frames, warmup, height)
            got = 1e3 / r["cpu_ms"]
            if height == ALTITUDE_M:
                fps[detector, n] = got
            lines.append(
                f"{detector:>9}{height:>7g}m{n:>8}{r['objects']:>9.0f}{r['cpu_ms']:>9.2f}{r['wall_ms']:>9.2f}"
                f"{r['sensing_ms']:>9.2f}{r['pipeline_ms']:>9.2f}{got:>10.1f}"
            )
    if ("ours", TARGET_SIZE) in fps:
        got = fps["ours", TARGET_SIZE]
        verdict = "PASS" if got >= TARGET_FPS else "MISS"
        lines.append(
            f"target: >= {TARGET_FPS:g} frames per CPU-second with ours at {TARGET_SIZE} persons"
            f" -> {verdict} ({got:.1f})"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sizes", type=int, nargs="+", default=[50, TARGET_SIZE])
    p.add_argument("--frames", type=int, default=60)
    p.add_argument("--warmup", type=int, default=10)
    p.add_argument("--close-m", type=float, default=CLOSE_M, help="the close look's height (15 m)")
    args = p.parse_args(argv)
    if args.frames < 1 or args.warmup < 0 or any(n < 0 for n in args.sizes) or not args.close_m > 0:
        p.error("--frames and --close-m must be positive, --warmup and --sizes not negative")
    print("\n".join(table(args.sizes, args.frames, args.warmup, args.close_m)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
