"""The simulated camera and object detector: frames at 30 Hz from the aircraft's pose, detections from the scene.

:class:`SimulatedCamera` turns a :class:`~flight.sim.simulator.VehicleState` (or a :class:`~flight.camera.CameraPose`)
into :class:`~flight.camera.Frame` s at the camera's rate, stamped with the sensors' health. :class:`SimulatedDetector`
implements :class:`~flight.camera.Detector`: it projects every actor's body box through the camera
(:func:`~flight.camera.project_points`) and decides, by the model below, what a YOLO-class detector would report.
A real detector (an ultralytics model of your own, reading ``frame.image``) plugs in behind the same protocol.

Detection model (all numbers are :class:`DetectionModel` fields)
-----------------------------------------------------------------
For each actor whose box lies at least ``min_visible_fraction`` = 0.5 inside the image:

* apparent size ``s = sqrt(w·h)`` of its projected box in pixels (straight down, ``s ≈ sqrt(L·W) / GSD``: a
  standing person, 0.5×0.5 m from above, is 18 px at 30 m and 9 px at 60 m with the default camera);
* size term ``f_size = 1 / (1 + exp(-(s - 8 px) / 2 px))`` (``size50_px``, ``size_width_px``): half the people
  8 px across are found, so recall falls with altitude (coarser ground sample distance);
* occlusion ``o``: the share of its box covered by the boxes of actors nearer the camera (capped at 1);
* crowd term ``f_crowd = exp(-ρ / 8)``, ρ the persons/m² within 2 m of it (``density_scale``,
  ``density_radius_m``): clutter and non-maximum suppression lose people in dense crowds;
* pose term ``f_pose``: 0.9 sitting, 0.8 lying (resting or collapsed), 1 otherwise (``pose_factor``): detectors
  trained on upright people do worse on lying ones, even though from straight above they are larger;
* sensor term ``k = camera × sqrt(thermal)``, the :class:`~flight.camera.SensorHealth` factors (1 when healthy);

``p = clip(0.95 · f_size · (1 - o) · f_crowd · f_pose / k, 0, 1)`` (``p_max`` = 0.95).

**Persistence.** Whether an actor is detected follows a two-state Markov chain per actor with stationary
probability ``p`` and lag-one correlation ``r = 0.6`` (``persistence``): after a hit ``P(hit) = p + r(1 - p)``,
after a miss ``P(hit) = p(1 - r)``, on entering the view ``P(hit) = p``. Misses come in runs (mean length
``1 / (p(1 - r))`` frames) while the long-run hit rate stays ``p``; ``r = 0`` makes frames independent.

**Confidence.** A hit's confidence is drawn from a beta distribution with mean
``μ = μ_class - 0.25(1 - f_size) - 0.15·o - 0.10(1 - 1/k)`` (clipped to 0.05–0.95) and concentration
``κ = 12`` (``Beta(μκ, (1 - μ)κ)``, standard deviation ``sqrt(μ(1 - μ)/13)`` ≈ 0.12 at μ = 0.72).
``μ_person = 0.72``, the paper's YOLO mean (0.716 over 44 scenes); ``μ_vehicle = 0.80``; other classes 0.65.
Hits below ``min_confidence`` = 0.25 (ultralytics' default threshold) are dropped.

**Boxes.** Each edge of a hit's box moves by a normal error of ``(1 px + 0.03 s) · k`` standard deviation
(``jitter_px``, ``jitter_fraction``), then the box is clipped to the image.

**False positives** (``truth_id`` ``None``, class ``person``): ``Poisson(0.3 · k)`` candidates per frame at
uniform pixels, kept where the pixel's ground point lies in a populated crowd zone (so the rate is 0.3 per frame
when crowds fill the view, ``false_positives_per_frame``), plus ``Poisson(0.02 · k)`` anywhere
(``background_false_positives_per_frame``). Each gets the box of a standing person at its ground point scaled by
U(0.8, 1.25) and confidence ``t + (1 - t)·Beta(2, 8)`` with ``t = min_confidence`` (mean 0.40). False positives
are independent from frame to frame.

Randomness comes from ``seed``: the same scene, seed and frames give the same detections.

>>> from flight.camera import CameraPose
>>> from flight.sim.scene_file import load_scene
>>> camera = SimulatedCamera()
>>> detector = SimulatedDetector(load_scene("scenes/hajj_emergency.yaml"), seed=1)
>>> frame = camera.capture(CameraPose(north_m=150.0, east_m=0.0, down_m=-30.0), time_s=0.0)
>>> hits = detector.detect(frame)
>>> casualty = [d for d in hits if d.truth_id == "P-12"]
>>> len(hits) > 100, len(casualty), casualty[0].class_name, 0.25 <= casualty[0].confidence <= 1.0
(True, 1, 'person', True)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from agentic_core.contracts.trusted import record_maker
from flight.camera import (
    BoundingBox,
    CameraPose,
    CameraSpec,
    Detection,
    Frame,
    SensorHealth,
    ground_points,
    pose_of,
    project_points,
)
from flight.sim.scene import SceneState
from flight.sim.scene_model import BEHAVIOURS, UPRIGHT, Behaviour, Scene

if TYPE_CHECKING:
    from flight.sim.simulator import VehicleState

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


CROWD_STEP_S = 0.1
"""The longest step of the crowd between two frames (s): a walker moves 13 cm in a step, and the heading and sway
processes are exact at any step; every frame is still taken at its own time. At a 5 Hz camera, two steps a frame
instead of six at 1/30 s: the crowd of a 9,000-person scene had been a third of a flight's computing."""
POSE_FACTOR: dict[Behaviour, float] = {"sitting": 0.9, "resting": 0.8, "collapsed": 0.8}


class DetectionModel(BaseModel):
    """The simulated detector's parameters; the module docstring gives the formulas they enter."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    p_max: float = Field(default=0.95, ge=0.0, le=1.0, description="detection probability at best")
    size50_px: float = Field(default=8.0, gt=0.0, description="apparent size detected half the time")
    size_width_px: float = Field(default=2.0, gt=0.0, description="how sharply detection falls with size")
    density_scale: float = Field(default=8.0, gt=0.0, description="persons/m² at which p falls by 1/e")
    density_radius_m: float = Field(default=2.0, gt=0.0)
    pose_factor: dict[Behaviour, float] = Field(default_factory=lambda: dict(POSE_FACTOR))
    confidence_mean: dict[str, float] = Field(default_factory=lambda: {"person": 0.72, "vehicle": 0.80})
    other_confidence_mean: float = Field(default=0.65, gt=0.0, lt=1.0)
    confidence_concentration: float = Field(default=12.0, gt=0.0)
    confidence_size_drop: float = 0.25
    confidence_occlusion_drop: float = 0.15
    confidence_health_drop: float = 0.10
    min_confidence: float = Field(default=0.25, ge=0.0, lt=1.0)
    persistence: float = Field(default=0.6, ge=0.0, lt=1.0, description="lag-one correlation of hits")
    min_visible_fraction: float = Field(default=0.5, gt=0.0, le=1.0)
    false_positives_per_frame: float = Field(default=0.3, ge=0.0, description="in a view full of crowd")
    background_false_positives_per_frame: float = Field(default=0.02, ge=0.0)
    jitter_px: float = Field(default=1.0, ge=0.0)
    jitter_fraction: float = Field(default=0.03, ge=0.0)


def visibility_factor(health: SensorHealth) -> float:
    """``k = camera × sqrt(thermal)``: how much worse than healthy the sensors behind a frame see."""
    return health.factor("camera") * math.sqrt(health.factor("thermal"))


@dataclass(frozen=True)
class InView:
    """The actors a frame sees and what the model makes of each (rows into the :class:`SceneState` arrays)."""

    rows: IntArray
    ids: list[str]
    boxes: FloatArray  # M×4 x_min, y_min, x_max, y_max, clipped to the image
    size_px: FloatArray
    occlusion: FloatArray
    density: FloatArray  # persons/m² around each actor
    p_detect: FloatArray
    confidence_mean: FloatArray


class SimulatedCamera:
    """Frames from the aircraft's pose at the camera's rate (30 Hz by default), without pixels.

    ``health`` is a :class:`~flight.camera.SensorHealth` or a function of time giving one (to degrade a sensor
    mid-flight); every frame carries the health at its time.
    """

    def __init__(
        self,
        spec: CameraSpec | None = None,
        health: SensorHealth | Callable[[float], SensorHealth] | None = None,
    ) -> None:
        self.spec = spec or CameraSpec()
        self.health = health or SensorHealth()
        self.frames_taken = 0
        self._next_s: float | None = None

    def health_at(self, time_s: float) -> SensorHealth:
        return self.health(time_s) if callable(self.health) else self.health

    def due(self, time_s: float) -> bool:
        """Whether the next frame is due at ``time_s`` (one per ``spec.frame_period_s``)."""
        return self._next_s is None or time_s >= self._next_s - 1e-9

    def capture(self, source: VehicleState | CameraPose, time_s: float | None = None) -> Frame:
        """A frame from a vehicle state (at its time) or a camera pose (at ``time_s``, default 0)."""
        if isinstance(source, CameraPose):
            pose, t = source, 0.0 if time_s is None else time_s
        else:
            pose, t = pose_of(source), source.time_s if time_s is None else time_s
        frame = Frame(index=self.frames_taken, time_s=t, spec=self.spec, pose=pose, health=self.health_at(t))
        self.frames_taken += 1
        self._next_s = t + self.spec.frame_period_s
        return frame


class SimulatedDetector:
    """The documented detection model over a scene; implements :class:`flight.camera.Detector`.

    Given a :class:`~flight.sim.scene_model.Scene` it builds its own :class:`SceneState`; given a state it shares
    it. Each :meth:`detect` first advances the state to the frame's time (a frame from the past sees the present).
    """

    def __init__(self, scene: Scene | SceneState, model: DetectionModel | None = None, seed: int = 0) -> None:
        self.state = scene if isinstance(scene, SceneState) else SceneState(scene)
        self.model = model or DetectionModel()
        self._rng = np.random.default_rng([seed, 2])
        n = len(self.state)
        self._hit = np.zeros(n, dtype=bool)
        self._last_frame = np.full(n, -10, dtype=np.int64)
        self._generation = self.state.generations.copy()
        codes = np.array([self.model.pose_factor.get(b, 1.0) for b in BEHAVIOURS])  # type: ignore[call-overload]
        self._pose = codes[self.state.behaviour_codes]
        means = self.model.confidence_mean
        self._class_mean = np.array(
            [means.get(name, self.model.other_confidence_mean) for name in self.state.class_names]
        )[self.state.class_codes]
        self._populated = [z for z in self.state.scene.zones if z.persons > 0]

    def in_view(self, frame: Frame) -> InView:
        """The deterministic half of the model: which actors the frame sees, their boxes and ``p``."""
        state, model, spec, pose = self.state, self.model, frame.spec, frame.pose
        state.advance_to(frame.time_s, max_dt=CROWD_STEP_S)
        rows = self.state.in_sight(spec, pose)
        corners = state.corners(rows)
        pixels, _ = project_points(spec, pose, corners.reshape(-1, 3))
        pixels = pixels.reshape(len(rows), 8, 2)
        in_front = ~np.isnan(pixels).any(axis=(1, 2))
        rows, pixels = rows[in_front], pixels[in_front]
        full = np.column_stack(
            [pixels[..., 0].min(1), pixels[..., 1].min(1), pixels[..., 0].max(1), pixels[..., 1].max(1)]
        )
        clipped = np.column_stack(
            [
                np.clip(full[:, 0], 0, spec.width_px),
                np.clip(full[:, 1], 0, spec.height_px),
                np.clip(full[:, 2], 0, spec.width_px),
                np.clip(full[:, 3], 0, spec.height_px),
            ]
        )
        area = np.maximum((full[:, 2] - full[:, 0]) * (full[:, 3] - full[:, 1]), 1e-9)
        seen = (clipped[:, 2] - clipped[:, 0]) * (clipped[:, 3] - clipped[:, 1])
        keep = (seen / area >= model.min_visible_fraction) & (clipped[:, 2] - clipped[:, 0] >= 1.0)
        keep &= clipped[:, 3] - clipped[:, 1] >= 1.0
        rows, pixels, full, clipped, area = rows[keep], pixels[keep], full[keep], clipped[keep], area[keep]
        silhouette = np.minimum(_silhouette_area(pixels), area)
        size = np.sqrt(silhouette)
        tops = np.column_stack([state.positions[rows], -state.sizes[rows, 2]])
        depth = np.linalg.norm(tops - pose.position, axis=1)
        occlusion = _occlusion(full, area, silhouette / area, depth)
        density = self._density(rows)
        f_size = 1.0 / (1.0 + np.exp(-(size - model.size50_px) / model.size_width_px))
        k = visibility_factor(frame.health)
        p = model.p_max * f_size * (1.0 - occlusion) * np.exp(-density / model.density_scale) * self._pose[rows] / k
        mean = (
            self._class_mean[rows]
            - model.confidence_size_drop * (1.0 - f_size)
            - model.confidence_occlusion_drop * occlusion
            - model.confidence_health_drop * (1.0 - 1.0 / k)
        )
        return InView(
            rows=rows,
            ids=[state.ids[i] for i in rows],
            boxes=clipped,
            size_px=size,
            occlusion=occlusion,
            density=density,
            p_detect=np.clip(p, 0.0, 1.0),
            confidence_mean=np.clip(mean, 0.05, 0.95),
        )

    def detect(self, frame: Frame) -> list[Detection]:
        """What the simulated detector reports for one frame, most confident first."""
        model, rng, view = self.model, self._rng, self.in_view(frame)
        rows, p = view.rows, view.p_detect
        fresh = (self._last_frame[rows] < frame.index - 1) | (self._generation[rows] != self.state.generations[rows])
        r = model.persistence
        p_hit = np.where(fresh, p, np.where(self._hit[rows], p + r * (1.0 - p), p * (1.0 - r)))
        hit = rng.random(len(rows)) < p_hit
        self._hit[rows] = hit
        self._last_frame[rows] = frame.index
        self._generation[rows] = self.state.generations[rows]
        kappa = model.confidence_concentration
        mu = view.confidence_mean
        confidence = rng.beta(mu * kappa, (1.0 - mu) * kappa)
        k = visibility_factor(frame.health)
        sigma = (model.jitter_px + model.jitter_fraction * view.size_px) * k
        boxes = view.boxes + rng.standard_normal((len(rows), 4)) * sigma[:, None]
        keep = hit & (confidence >= model.min_confidence)
        out = _detections(
            [self.state.class_names[c] for c in self.state.class_codes[rows[keep]]],
            boxes[keep],
            confidence[keep],
            [self.state.ids[i] for i in rows[keep]],
            frame.spec,
        )
        out += self._false_positives(frame, k)
        out.sort(key=lambda d: -d.confidence)
        return out

    def _density(self, rows: IntArray) -> FloatArray:
        """Persons per m² within ``density_radius_m`` of each row's actor (not counting itself)."""
        if len(rows) == 0:
            return np.zeros(0)
        radius = self.model.density_radius_m
        persons = self.state.person_mask
        pos = self.state.positions
        lo, hi = pos[rows].min(axis=0) - radius, pos[rows].max(axis=0) + radius
        near = persons & (pos[:, 0] >= lo[0]) & (pos[:, 0] <= hi[0]) & (pos[:, 1] >= lo[1]) & (pos[:, 1] <= hi[1])
        tree = cKDTree(pos[near])
        counts = np.asarray(tree.query_ball_point(pos[rows], radius, return_length=True), dtype=float)
        counts -= persons[rows]  # itself
        density: FloatArray = counts / (math.pi * radius * radius)
        return density

    def _false_positives(self, frame: Frame, k: float) -> list[Detection]:
        model, rng, spec = self.model, self._rng, frame.spec
        n_crowd = rng.poisson(model.false_positives_per_frame * k)
        n_background = rng.poisson(model.background_false_positives_per_frame * k)
        n = n_crowd + n_background
        if n == 0:
            return []
        pixels = rng.random((n, 2)) * np.array([spec.width_px, spec.height_px])
        ground, hits = ground_points(spec, frame.pose, pixels)
        in_crowd = np.zeros(n, dtype=bool)
        for zone in self._populated:
            in_crowd[hits] |= zone.contains(ground[hits])
        keep = hits & (in_crowd | (np.arange(n) >= n_crowd))
        scale = rng.uniform(0.8, 1.25, n)
        confidence = model.min_confidence + (1.0 - model.min_confidence) * rng.beta(2.0, 8.0, n)
        boxes = []
        for g, s in zip(ground[keep], scale[keep], strict=True):
            half = s * UPRIGHT.width_m / 2.0
            body = np.array(
                [[g[0] + dn, g[1] + de, dd] for dn in (-half, half) for de in (-half, half) for dd in (0.0, -s * 1.7)]
            )
            px, _ = project_points(spec, frame.pose, body)
            boxes.append([px[:, 0].min(), px[:, 1].min(), px[:, 0].max(), px[:, 1].max()])
        box_array = np.array(boxes, dtype=float).reshape(-1, 4)
        good = ~np.isnan(box_array).any(axis=1)
        k_fp = int(good.sum())
        return _detections(["person"] * k_fp, box_array[good], confidence[keep][good], [None] * k_fp, spec)


_new_box = record_maker(BoundingBox)
_new_detection = record_maker(Detection)


def _detections(
    classes: list[str], boxes: FloatArray, confidence: FloatArray, truth: list[str | None], spec: CameraSpec
) -> list[Detection]:
    """:class:`Detection` s from trusted numbers, boxes clipped to the image and ordered; built without
    re-validation (:mod:`agentic_core.contracts.trusted`), since a thousand per frame is the perception benchmark's
    load."""
    x = np.clip(boxes[:, [0, 2]], 0.0, spec.width_px)
    y = np.clip(boxes[:, [1, 3]], 0.0, spec.height_px)
    edges = np.column_stack([x.min(axis=1), y.min(axis=1), x.max(axis=1), y.max(axis=1)]).tolist()
    conf = np.clip(confidence, 0.0, 1.0).tolist()
    new_detection, new_box = _new_detection, _new_box
    return [
        new_detection(
            {
                "class_name": c,
                "box": new_box({"x_min": x0, "y_min": y0, "x_max": x1, "y_max": y1}),
                "confidence": p,
                "truth_id": t,
            }
        )
        for c, (x0, y0, x1, y1), p, t in zip(classes, edges, conf, truth, strict=True)
    ]


def _silhouette_area(pixels: FloatArray) -> FloatArray:
    """Approximate pixel area of each body's outline (M×8×2 projected box corners, ground face first): its top
    face swept along the lean from the ground face to the top face."""
    top, bottom = pixels[:, 4:], pixels[:, :4]
    x, y = top[..., 0], top[..., 1]
    face = 0.5 * np.abs((x * np.roll(y, -1, axis=1) - y * np.roll(x, -1, axis=1)).sum(axis=1))
    lean = top.mean(axis=1) - bottom.mean(axis=1)
    length = np.hypot(lean[:, 0], lean[:, 1])
    normal = np.column_stack([-lean[:, 1], lean[:, 0]]) / np.maximum(length, 1e-12)[:, None]
    across = np.einsum("mkj,mj->mk", top, normal)
    swept: FloatArray = face + length * (across.max(axis=1) - across.min(axis=1))
    return swept


def _occlusion(boxes: FloatArray, area: FloatArray, fill: FloatArray, depth: FloatArray) -> FloatArray:
    """The share (0–1) of each body hidden by bodies nearer the camera: the overlap of their boxes, times the
    share of the nearer box its outline fills (``fill``), over the farther box's area."""
    occ = np.zeros(len(boxes))
    if len(boxes) < 2:
        return occ
    centres = (boxes[:, :2] + boxes[:, 2:]) / 2.0
    half_diag = np.hypot(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1]) / 2.0
    pairs = cKDTree(centres).query_pairs(2.0 * float(half_diag.max()), output_type="ndarray")
    if len(pairs) == 0:
        return occ
    i, j = pairs[:, 0], pairs[:, 1]
    w = np.minimum(boxes[i, 2], boxes[j, 2]) - np.maximum(boxes[i, 0], boxes[j, 0])
    h = np.minimum(boxes[i, 3], boxes[j, 3]) - np.maximum(boxes[i, 1], boxes[j, 1])
    overlap = np.clip(w, 0.0, None) * np.clip(h, 0.0, None)
    behind = np.where(depth[i] > depth[j], i, j)  # the farther one of each pair is the one hidden
    front = np.where(depth[i] > depth[j], j, i)
    np.add.at(occ, behind, overlap * fill[front])
    covered: FloatArray = np.minimum(occ / area, 1.0)
    return covered
