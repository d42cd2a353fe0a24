"""What one rendered frame costs (:mod:`flight.sim.render`): the table ``benchmarks/perception.py`` prints after
its own.

For each crowd size N (0, 50 and 200 by default) a walkway fills the ground a 640×480 camera (84°, straight down)
sees from 30 m, holding exactly N persons (its default mix of walkers and standers, plus sitting and lying ones),
and the camera drifts north at 0.6 m/s while the aircraft reports 5 m/s (motion blur is computed). The scene is
moved to each frame's time before the clock starts, so the time is the renderer's alone: ground, shadows, people,
sensor. The first ``warmup`` frames (the ground's tiles rasterised, the mosaic assembled) are not timed. The
table gives the mean and the 95th percentile of the wall clock and the median CPU time of this process per frame
(on a shared machine the wall clock also counts waiting for a core).

Target: mean ≤ 15 ms per frame at 200 persons, on one core.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from agentic_core.contracts.camera import CameraPose
from flight.sim.render import SceneRenderer
from flight.sim.render.camera import render_spec
from flight.sim.scene_model import NE, Scene, Zone

TARGET_MS = 15.0
TARGET_SIZE = 200
ALTITUDE_M = 30.0
MIX = {"walking": 0.6, "standing": 0.2, "sitting": 0.1, "resting": 0.1}


def crowd_scene(n: int) -> Scene:
    """A walkway of exactly ``n`` persons filling the view from 30 m (48 × 34 m)."""
    half_n, half_e = 17.0, 24.0
    corners = [(-half_n, -half_e), (half_n, -half_e), (half_n, half_e), (-half_n, half_e)]
    zone = Zone(
        id="Z-bench", kind="walkway", polygon=[NE(north=a, east=b) for a, b in corners],
        density=n / (4 * half_n * half_e), mix=MIX,
    )  # fmt: skip
    return Scene(id=f"render-bench-{n}", seed=n + 1, zones=[zone])


def run_once(n: int, frames: int, warmup: int, seed: int) -> dict[str, list[float]]:
    """Wall and CPU seconds of each timed frame, and persons shown."""
    spec = render_spec()
    renderer = SceneRenderer(crowd_scene(n), seed=seed)
    out: dict[str, list[float]] = {"wall": [], "cpu": [], "shown": []}
    for k in range(warmup + frames):
        t = k * spec.frame_period_s
        renderer.state.advance_to(t)
        pose = CameraPose(north_m=0.6 * t - 1.0, east_m=0.0, down_m=-ALTITUDE_M)
        wall, cpu = time.perf_counter(), time.process_time()
        rendered = renderer.render(spec, pose, frame_index=k, velocity_ned=(5.0, 0.0, 0.0))
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        if k >= warmup:
            out["wall"].append(wall)
            out["cpu"].append(cpu)
            out["shown"].append(float(len(rendered.persons.ids)))
    return out


def render_section(sizes: list[int], frames: int, warmup: int, repeats: int) -> list[str]:
    """The render table's lines."""
    lines = [
        "render benchmark (flight.sim.render: 640x480, 84 deg, straight down, 30 m)",
        f"{frames} timed frames x {repeats} repeats per size, after {warmup} warm-up; ms per frame",
        f"{'persons':>8}{'shown':>8}{'mean':>9}{'p95':>9}{'cpu':>9}",
    ]
    means: dict[int, float] = {}
    for n in sizes:
        runs = [run_once(n, frames, warmup, seed) for seed in range(repeats)]
        wall = [v for r in runs for v in r["wall"]]
        cpu = [v for r in runs for v in r["cpu"]]
        shown = statistics.mean(v for r in runs for v in r["shown"])
        means[n] = 1e3 * statistics.mean(wall)
        lines.append(
            f"{n:>8}{shown:>8.0f}{means[n]:>9.2f}{1e3 * float(np.percentile(wall, 95)):>9.2f}"
            f"{1e3 * statistics.median(cpu):>9.2f}"
        )
    if TARGET_SIZE in means:
        verdict = "PASS" if means[TARGET_SIZE] <= TARGET_MS else "MISS"
        lines.append(f"render target: mean <= {TARGET_MS:g} ms at {TARGET_SIZE} persons -> {verdict}")
    return lines


__all__ = ["crowd_scene", "render_section", "run_once"]
