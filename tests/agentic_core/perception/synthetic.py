"""Test helper: known ground tracks projected through the camera into noisy detections (no scene simulator).

People are placed at least ``min_gap_m`` apart; walkers share a direction (a flow) with personal speeds, so they
keep their distance for the run; the rest stand still. Each frame every body centre (0.85 m up, where the tracker
assumes a person's box centre is) is projected with ``flight.camera.project_points`` into a box the size of a
0.6 m wide body at that range, its edges jittered by ``(jitter_px + 3 % of the box)·k`` pixels (k: the camera's
degradation factor), each person detected with probability ``p_detect``; ``false_per_frame`` false positives per
frame (Poisson) land at uniform pixels. ``truth_id`` is set, but the tracker never reads it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from flight.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame, SensorHealth, project_points


@dataclass
class SyntheticScene:
    walkers: int = 20
    still: int = 10
    area_m: tuple[float, float, float, float] = (-14.0, 14.0, -26.0, 26.0)  # north min/max, east min/max
    min_gap_m: float = 3.0
    flow_heading_deg: float = 0.0
    speed_mps: tuple[float, float] = (1.0, 1.2)
    p_detect: float = 0.9
    false_per_frame: float = 0.5
    jitter_px: float = 1.0
    seed: int = 0
    health: SensorHealth = field(default_factory=SensorHealth)

    def people(self, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        n = self.walkers + self.still
        n0, n1, e0, e1 = self.area_m
        pos: list[np.ndarray] = []
        while len(pos) < n:
            p = rng.uniform([n0, e0], [n1, e1])
            if all(math.dist(p, q) >= self.min_gap_m for q in pos):
                pos.append(p)
        heading = math.radians(self.flow_heading_deg)
        speed = rng.uniform(*self.speed_mps, n)
        speed[self.walkers :] = 0.0
        vel = np.column_stack([math.cos(heading) * speed, math.sin(heading) * speed])
        return np.array(pos), vel


def run(
    scene: SyntheticScene,
    frames: int,
    *,
    pose: CameraPose | None = None,
    drone_velocity: tuple[float, float] = (0.0, 0.0),
    spec: CameraSpec | None = None,
) -> Iterator[tuple[Frame, list[Detection], dict[str, tuple[float, float]]]]:
    """Each frame, its detections, and the truth in view (person id -> north/east)."""
    spec = spec or CameraSpec()
    start = pose or CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    rng = np.random.default_rng(scene.seed)
    pos, vel = scene.people(rng)
    ids = [f"T{i}" for i in range(len(pos))]
    k_cam = scene.health.factor("camera")
    dt = spec.frame_period_s
    for k in range(frames):
        t = k * dt
        here = start.model_copy(
            update={"north_m": start.north_m + drone_velocity[0] * t, "east_m": start.east_m + drone_velocity[1] * t}
        )
        now = pos + vel * t
        centres = np.column_stack([now, np.full(len(now), -0.85)])
        pixels, visible = project_points(spec, here, centres)
        half = 0.3 * spec.focal_px / np.linalg.norm(centres - here.position, axis=1)
        edges = np.column_stack([pixels - half[:, None], pixels + half[:, None]])
        edges += rng.standard_normal(edges.shape) * ((scene.jitter_px + 0.03 * 2 * half) * k_cam)[:, None]
        edges = np.clip(edges, 0.0, [spec.width_px, spec.height_px, spec.width_px, spec.height_px])
        hit = visible & (rng.random(len(now)) < scene.p_detect)
        dets = [_detection(e, 0.8, ids[i]) for i, e in zip(np.flatnonzero(hit), edges[hit], strict=True)]
        for _ in range(rng.poisson(scene.false_per_frame)):
            u, v = rng.uniform(0, spec.width_px), rng.uniform(0, spec.height_px)
            dets.append(_detection(np.array([u - 15, v - 15, u + 15, v + 15]), 0.4, None))
        truth = {ids[i]: (float(now[i, 0]), float(now[i, 1])) for i in np.flatnonzero(visible)}
        yield Frame(index=k, time_s=t, spec=spec, pose=here, health=scene.health), dets, truth


def _detection(edges: np.ndarray, confidence: float, truth: str | None) -> Detection:
    a, b, c, d = (float(x) for x in edges)
    box = BoundingBox(x_min=min(a, c), y_min=min(b, d), x_max=max(a, c), y_max=max(b, d))
    return Detection(class_name="person", box=box, confidence=confidence, truth_id=truth)
