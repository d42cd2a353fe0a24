"""What one perception update costs: detections → tracks → scene graph → World Model Contract.

For each crowd size (50, 200 and 1,000 persons in view by default) N people stand or walk on the ground under
the default camera (nadir, 1920×1080, 84°) hovering 30 m up: 30 % stand still, 70 % walk at 0.8–1.4 m/s and
turn back at the edge of the view, so all N stay in it. Each frame their body centres (0.85 m up) are projected
with ``flight.camera.project_points`` into boxes the size of a person at that range, the edges jittered by
1 px + 3 % of the box (the simulated detector's model), each person detected with probability 0.9. Detections
are made just before each update, as a detector would, and not timed.

After ``--warmup`` frames (tracks confirmed, relations in place) ``--frames`` updates are timed, stage by stage
(``Perception.timings``): ground measurements, tracking (predict, gate, assign, update, life cycle), relations
(KD-tree queries, zones), contract (the pydantic WorldModel the consumers get, every record in it: its bounds
checked on the arrays at once, its records then built without validating each again; see
``Perception.contract``). The networkx scene graph is brought up to date only when read; the cost of reading it
after an update is shown apart ("graph on read"). Each size runs ``--repeats`` times with a fresh pipeline; the
table gives the median over all timed frames (wall clock), the median CPU time of this process per update
("cpu": on a shared machine the wall clock also counts the time spent waiting for a core), the 95th
percentile, and the spread of the per-repeat medians (min–max), since a shared machine is noisy.

Target: under 5 ms per update (median) with 200 persons in view.

Then the renderer's table (``benchmarks/render_timing.py``): render time per 640×480 frame (mean, p95, CPU) at
``--render-sizes`` persons (0, 50, 200), target a mean ≤ 15 ms at 200.

Usage: ``python benchmarks/perception.py [--sizes 50 200 1000] [--frames 150] [--repeats 3] [--quick]
[--render-sizes 0 50 200]``. Exit
status 0 whether the target is met or not (``--strict``: 1 on MISS).
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from detect_timing import detect_section  # noqa: E402  (beside this script)
from render_timing import render_section  # noqa: E402  (beside this script)

from agentic_core.perception.pipeline import STAGES, Perception  # noqa: E402
from flight.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame, footprint, project_points  # noqa: E402

TABLE_HEADER = "perception update benchmark"
TARGET_MS = 5.0
TARGET_SIZE = 200
HOME = (21.4133, 39.8933, 300.0)


class Crowd:
    """N people inside the camera's footprint (shrunk by 2 m), walking or standing, bouncing off its edges."""

    def __init__(self, n: int, spec: CameraSpec, pose: CameraPose, seed: int) -> None:
        corners = footprint(spec, pose)
        assert corners is not None
        self.lo, self.hi = corners.min(axis=0) + 2.0, corners.max(axis=0) - 2.0
        self.rng = np.random.default_rng(seed)
        self.pos = self.lo + (self.hi - self.lo) * self.rng.random((n, 2))
        heading = self.rng.uniform(0, 2 * np.pi, n)
        speed = np.where(self.rng.random(n) < 0.3, 0.0, self.rng.uniform(0.8, 1.4, n))
        self.vel = np.column_stack([np.cos(heading), np.sin(heading)]) * speed[:, None]
        self.spec, self.pose = spec, pose

    def step(self, dt: float) -> None:
        self.pos += self.vel * dt
        out_lo, out_hi = self.pos < self.lo, self.pos > self.hi
        self.vel[out_lo | out_hi] *= -1.0
        self.pos = np.clip(self.pos, self.lo, self.hi)

    def detections(self) -> list[Detection]:
        spec, pose, rng = self.spec, self.pose, self.rng
        n = len(self.pos)
        centres = np.column_stack([self.pos, np.full(n, -0.85)])
        pixels, visible = project_points(spec, pose, centres)
        half = 0.3 * spec.focal_px / np.linalg.norm(centres - pose.position, axis=1)  # a 0.6 m wide body
        size = 2.0 * half
        edges = np.column_stack([pixels - half[:, None], pixels + half[:, None]])
        edges += rng.standard_normal((n, 4)) * (1.0 + 0.03 * size)[:, None]
        keep = visible & (rng.random(n) < 0.9)
        edges = np.clip(edges[keep], 0.0, [spec.width_px, spec.height_px, spec.width_px, spec.height_px])
        conf = rng.uniform(0.5, 0.95, len(edges))
        return [
            Detection(
                class_name="person",
                box=BoundingBox(x_min=min(a, c), y_min=min(b, d), x_max=max(a, c), y_max=max(b, d)),
                confidence=float(p),
            )
            for (a, b, c, d), p in zip(edges.tolist(), conf, strict=True)
        ]


def run_once(n: int, frames: int, warmup: int, seed: int) -> dict[str, list[float]]:
    """Per-frame seconds of each stage, the total, and the graph read, for one fresh pipeline."""
    spec = CameraSpec()
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    crowd = Crowd(n, spec, pose, seed)
    perception = Perception(home=HOME)
    out: dict[str, list[float]] = {key: [] for key in (*STAGES, "total", "cpu", "graph")}
    period = spec.frame_period_s
    for k in range(warmup + frames):
        crowd.step(period)
        detections = crowd.detections()
        frame = Frame(index=k, time_s=k * period, spec=spec, pose=pose)
        start, start_cpu = time.perf_counter(), time.process_time()
        perception.update(frame, detections)
        total, cpu = time.perf_counter() - start, time.process_time() - start_cpu
        start = time.perf_counter()
        perception.scene_graph.graph  # noqa: B018 - reading it brings it up to date
        graph = time.perf_counter() - start
        if k >= warmup:
            for stage in STAGES:
                out[stage].append(perception.timings[stage])
            out["total"].append(total)
            out["cpu"].append(cpu)
            out["graph"].append(graph)
    return out


def p95(values: list[float]) -> float:
    return float(np.percentile(values, 95))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[50, 200, 1000], help="persons in view")
    parser.add_argument("--frames", type=int, default=150, help="timed updates per repeat")
    parser.add_argument("--warmup", type=int, default=30, help="untimed updates first")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="a fast smoke run: 30 frames, 1 repeat")
    parser.add_argument("--strict", action="store_true", help="exit 1 when the target is missed")
    parser.add_argument(
        "--render-sizes", type=int, nargs="*", default=[0, 50, 200], help="persons in the rendered view (none: skip)"
    )
    parser.add_argument("--detect", type=int, default=0, metavar="N", help="also time our detector on N frames")
    args = parser.parse_args(argv)
    if args.quick:
        args.frames, args.warmup, args.repeats = 30, 10, 1
    if min(args.sizes) < 1 or args.frames < 1 or args.repeats < 1:
        parser.error("sizes, --frames and --repeats must be at least 1")

    print(TABLE_HEADER)
    print(f"{args.frames} timed updates x {args.repeats} repeats per size, after {args.warmup} warm-up; ms per update")
    stage_cols = "".join(f"{s:>11}" for s in STAGES)
    print(
        f"{'persons':>8}{stage_cols}{'total':>9}{'cpu':>8}{'p95':>8}{'spread':>15}{'us/person':>11}"
        f"{'graph on read':>15}"
    )
    medians: dict[int, float] = {}
    cpu_medians: dict[int, float] = {}
    for n in args.sizes:
        runs = [run_once(n, args.frames, args.warmup, seed) for seed in range(args.repeats)]
        merged = {key: [v for r in runs for v in r[key]] for key in runs[0]}
        ms = {key: 1e3 * statistics.median(values) for key, values in merged.items()}
        per_repeat = [1e3 * statistics.median(r["total"]) for r in runs]
        medians[n] = ms["total"]
        cpu_medians[n] = ms["cpu"]
        spread = f"{min(per_repeat):.2f}-{max(per_repeat):.2f}"
        stages = "".join(f"{ms[s]:>11.2f}" for s in STAGES)
        print(
            f"{n:>8}{stages}{ms['total']:>9.2f}{ms['cpu']:>8.2f}{1e3 * p95(merged['total']):>8.2f}{spread:>15}"
            f"{1e3 * ms['total'] / n:>11.1f}{ms['graph']:>15.2f}"
        )
    sizes = sorted(medians)
    if len(sizes) >= 2:
        growth = ", ".join(
            f"{a}->{b} persons: x{medians[b] / medians[a]:.1f} time for x{b / a:g} persons"
            for a, b in itertools.pairwise(sizes)
        )
        print(f"growth: {growth}")
    verdict = "n/a"
    if TARGET_SIZE in medians:
        verdict = "PASS" if medians[TARGET_SIZE] < TARGET_MS else "MISS"
        print(
            f"target: median < {TARGET_MS:g} ms at {TARGET_SIZE} persons -> {verdict} ({medians[TARGET_SIZE]:.2f} ms;"
            f" CPU {cpu_medians[TARGET_SIZE]:.2f} ms)"
        )
    else:
        print(f"target: median < {TARGET_MS:g} ms at {TARGET_SIZE} persons -> n/a (size not run)")
    if args.render_sizes:
        print("\n".join(["", *render_section(args.render_sizes, args.frames, args.warmup, args.repeats)]))
    if args.detect:
        print(detect_section(args.detect))
    return 1 if args.strict and verdict == "MISS" else 0


if __name__ == "__main__":
    sys.exit(main())
