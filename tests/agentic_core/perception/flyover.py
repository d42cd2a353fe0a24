"""Test helper: fly a straight-leg path over a simulated scene and run perception on every 30 Hz frame.

The aircraft flies each leg at constant speed and altitude, facing along it, with the default nadir camera; the
simulated detector (flight.sim.detector) makes the detections; perception never sees ``truth_id``. Each frame's
record carries the ground truth in view (the detector's own notion: at least half the body box in the image), so
tests can score tracks against it with :class:`agentic_core.perception.metrics.TrackingScore`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from agentic_core.perception.metrics import TrackingScore
from agentic_core.perception.pipeline import Perception, PerceptionConfig
from agentic_core.perception.tracker import CONFIRMED
from agentic_core.perception.world_model import WorldModel
from flight.camera import CameraPose, Detection, Frame, SensorHealth
from flight.sim.detector import SimulatedCamera, SimulatedDetector
from flight.sim.scene_model import Scene


@dataclass(frozen=True)
class Leg:
    """Fly from ``start`` to ``end`` (north, east metres) at ``alt_m`` and ``speed_mps``; speed 0 hovers at
    ``start`` for ``hover_s``."""

    start: tuple[float, float]
    end: tuple[float, float]
    alt_m: float = 30.0
    speed_mps: float = 5.0
    hover_s: float = 0.0

    @property
    def duration_s(self) -> float:
        if self.speed_mps <= 0.0:
            return self.hover_s
        return math.dist(self.start, self.end) / self.speed_mps

    def pose(self, t: float) -> CameraPose:
        (n0, e0), (n1, e1) = self.start, self.end
        length = math.dist(self.start, self.end)
        yaw = math.atan2(e1 - e0, n1 - n0) if length > 0 else 0.0
        f = 0.0 if self.speed_mps <= 0.0 or length == 0 else min(1.0, t * self.speed_mps / length)
        return CameraPose(north_m=n0 + f * (n1 - n0), east_m=e0 + f * (e1 - e0), down_m=-self.alt_m, yaw_rad=yaw)


@dataclass(frozen=True)
class Step:
    """One frame of a fly-over: what was seen, what perception made of it, and the truth in view."""

    frame: Frame
    detections: list[Detection]
    world: WorldModel
    truth: dict[str, tuple[float, float]]  # persons in view: id -> north/east
    confirmed: dict[str, tuple[float, float]]  # confirmed person tracks: id -> north/east


def fly(
    scene: Scene,
    legs: Sequence[Leg],
    *,
    seed: int = 1,
    config: PerceptionConfig | None = None,
    health: SensorHealth | Callable[[float], SensorHealth] | None = None,
    with_truth: bool = True,
) -> Iterator[Step]:
    """Every frame of the flight, in order (a generator: stop early by breaking out)."""
    camera = SimulatedCamera(health=health)
    detector = SimulatedDetector(scene, seed=seed)
    home = scene.home
    perception = Perception(home=(home.lat_deg, home.lon_deg, home.alt_msl_m), config=config, landmarks=scene.landmarks)
    period = camera.spec.frame_period_s
    t0 = 0.0
    for leg in legs:
        frames = max(1, round(leg.duration_s / period))
        for k in range(frames):
            t = t0 + k * period
            frame = camera.capture(leg.pose(k * period), time_s=t)
            detections = detector.detect(frame)
            world = perception.update(frame, detections)
            truth: dict[str, tuple[float, float]] = {}
            if with_truth:
                view = detector.in_view(frame)
                persons = detector.state.person_mask[view.rows]
                pos = detector.state.positions[view.rows]
                truth = {i: (float(p[0]), float(p[1])) for i, p, ok in zip(view.ids, pos, persons, strict=True) if ok}
            tracks = perception.tracks
            assert tracks is not None
            rows = np.flatnonzero((tracks.state == CONFIRMED) & np.array([c == "person" for c in tracks.classes]))
            confirmed = {tracks.ids[r]: (float(tracks.x[r, 0]), float(tracks.x[r, 1])) for r in rows}
            yield Step(frame, detections, world, truth, confirmed)
        t0 += frames * period


def score_flight(steps: Iterator[Step], max_distance_m: float = 1.0) -> TrackingScore:
    """Run a fly-over to the end and score its confirmed person tracks against the truth in view."""
    score = TrackingScore(max_distance_m=max_distance_m)
    for step in steps:
        score.add(step.truth, step.confirmed)
    return score
