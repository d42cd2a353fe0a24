"""From pixel boxes to ground positions with covariances: what the tracker measures, and how sure it can be.

A detection's box centre is cast through the camera model onto a horizontal plane
(:func:`agentic_core.contracts.pinhole.ground_points`). Why the centre: the default camera looks straight down, where
the bottom edge of a person's box is not their feet (from above, the feet are inside the box) but the box spans feet
to head, leaning away from the nadir; its centre marks the body's middle, half its height up. So each class names the
height its box centre marks (``centre_height_m``: 0.85 m for a person, standing or walking as most are) and the centre
is cast onto that plane, which puts the point over the feet at any gimbal pitch: on the simulated Hajj crowds this
halves the position error against casting onto the ground (0.55 → 0.16–0.26 m RMSE). A person lying down (box centre
0.15 m up) is then placed ``0.7 m · offset / height`` towards the nadir (0.33 m at 14 m offset, 30 m up); that
ambiguity is in each object's reported covariance (``centre_height_sigma_m``).

Noise splits in two, because the two behave differently:

* per detection, white from frame to frame: the box's localisation (``pixel_sigma_px``, plus a fraction of the
  box's size, plus half its extent along an axis where the image's edge cuts it), attitude jitter
  (``attitude_sigma_deg``, which moves the image by ``focal·angle`` pixels) and the position fix's frame-to-frame
  jitter. Pixels are carried to metres by the local Jacobian of the pixel→ground
  map, so an oblique view's stretched footprint gets a stretched covariance. This is the tracker's ``R``.
* common to the whole frame, slowly varying: the absolute error of the aircraft's position (GPS horizontally,
  barometer vertically; a height error scales every ground offset from the nadir point). It moves all targets
  together, so it does not enter ``R`` (the tracker would otherwise smooth relative motion it can see); it is
  added to each object's reported covariance and is the ego pose's covariance.

Degraded sensors (:class:`agentic_core.contracts.camera.SensorHealth`) multiply their terms: ``camera`` and
``thermal`` the pixel noise, ``imu`` the attitude jitter, ``gps`` the fix (jitter and absolute), ``baro`` the height.

>>> from agentic_core.contracts.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame
>>> frame = Frame(index=0, time_s=0.0, spec=CameraSpec(), pose=CameraPose(north_m=0, east_m=0, down_m=-30))
>>> box = BoundingBox(x_min=950, y_min=530, x_max=970, y_max=550)
>>> m = ground_measurements(frame, [Detection(class_name="person", box=box, confidence=0.9)], NoiseModel())
>>> np.round(m.z, 3).tolist(), bool(0.0 < m.R[0, 0, 0] < 0.01)
([[0.0, 0.0]], True)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from operator import attrgetter

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field

from agentic_core.contracts.camera import CameraPose, CameraSpec, Detection, Frame, SensorHealth
from agentic_core.contracts.pinhole import ground_points

FloatArray = NDArray[np.float64]


class NoiseModel(BaseModel):
    """The sensor noise perception assumes, before degraded sensors inflate it (one sigma each)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    pixel_sigma_px: float = Field(default=1.0, ge=0, description="box-centre localisation, pixels")
    box_sigma_frac: float = Field(default=0.02, ge=0, description="extra localisation, fraction of the box diagonal")
    attitude_sigma_deg: float = Field(default=0.05, ge=0, description="camera attitude jitter per frame")
    position_jitter_m: float = Field(default=0.02, ge=0, description="the position fix's frame-to-frame jitter")
    gps_sigma_m: float = Field(default=1.0, ge=0, description="absolute horizontal position error of the fix")
    vertical_sigma_m: float = Field(default=1.5, ge=0, description="absolute height error (barometer)")
    ground_down_m: float = Field(default=0.0, description="the ground plane, metres below home")
    centre_height_m: dict[str, float] = Field(
        default_factory=lambda: {"person": 0.85, "vehicle": 0.75},
        description="height above ground that a class's box centre marks (others: 0, the ground)",
    )
    centre_height_sigma_m: float = Field(
        default=0.35, ge=0, description="how far off that height may be (a person lying, not standing: 0.7 m)"
    )


@dataclass(frozen=True)
class Measurements:
    """The frame's detections that meet the ground, as ground points with covariances.

    ``index`` maps each row back to the detection list; detections whose ray misses the ground are dropped.
    """

    z: FloatArray  # N×2 north/east, m
    R: FloatArray  # N×2×2, m²
    classes: list[str]
    conf: FloatArray  # N
    boxes: FloatArray  # N×4 pixel boxes (x_min, y_min, x_max, y_max)
    index: NDArray[np.intp]

    def __len__(self) -> int:
        return len(self.z)


def pixel_sigma(noise: NoiseModel, spec: CameraSpec, health: SensorHealth, boxes: FloatArray) -> FloatArray:
    """Per-detection pixel noise: localisation (grown by camera/thermal trouble) and attitude jitter (imu)."""
    diag = np.hypot(boxes[:, 2] - boxes[:, 0], boxes[:, 3] - boxes[:, 1])
    local = np.hypot(noise.pixel_sigma_px, noise.box_sigma_frac * diag) * max(
        health.factor("camera"), health.factor("thermal")
    )
    attitude = spec.focal_px * math.radians(noise.attitude_sigma_deg) * health.factor("imu")
    sigma: FloatArray = np.hypot(local, attitude)
    return sigma


def clipped_sigma(spec: CameraSpec, boxes: FloatArray, sigma: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Pixel noise across (u) and down (v) the image: a box cut by the image's edge hides how far the object goes
    on that side, so its centre is uncertain by up to half its visible extent along that axis (an object entering
    the view would otherwise seem to move as more of it appears)."""
    edge = 3.0 * sigma  # a cut edge, jittered like any other, lands within 3 sigma of the border
    cut_u = (boxes[:, 0] <= edge) | (boxes[:, 2] >= spec.width_px - edge)
    cut_v = (boxes[:, 1] <= edge) | (boxes[:, 3] >= spec.height_px - edge)
    su: FloatArray = np.hypot(sigma, np.where(cut_u, (boxes[:, 2] - boxes[:, 0]) / 2.0, 0.0))
    sv: FloatArray = np.hypot(sigma, np.where(cut_v, (boxes[:, 3] - boxes[:, 1]) / 2.0, 0.0))
    return su, sv


_corners = attrgetter("x_min", "y_min", "x_max", "y_max")
"""A box's corners as a tuple, in one call."""


def ground_measurements(frame: Frame, detections: Sequence[Detection], noise: NoiseModel) -> Measurements:
    """The detections of one frame as ground points with their per-detection covariance ``R``."""
    n = len(detections)
    boxes = np.array([_corners(d.box) for d in detections], dtype=float).reshape(n, 4)
    classes = [d.class_name for d in detections]
    conf = np.array([d.confidence for d in detections], dtype=float)
    centre = np.column_stack([(boxes[:, 0] + boxes[:, 2]) / 2.0, (boxes[:, 1] + boxes[:, 3]) / 2.0])
    plane = np.full(n, noise.ground_down_m)
    if noise.centre_height_m:
        lift = {c: noise.centre_height_m.get(c, 0.0) for c in dict.fromkeys(classes)}  # the frame's few classes
        plane -= next(iter(lift.values())) if len(lift) == 1 else np.array([lift[c] for c in classes])
    z, J, hit = _cast(frame.spec, frame.pose, centre, plane)
    sigma = pixel_sigma(noise, frame.spec, frame.health, boxes)
    su, sv = clipped_sigma(frame.spec, boxes, sigma)
    R = np.einsum("nij,nj,nkj->nik", J, np.column_stack([su**2, sv**2]), J)
    jitter = (noise.position_jitter_m * frame.health.factor("gps")) ** 2
    R[:, 0, 0] += jitter
    R[:, 1, 1] += jitter
    keep = np.flatnonzero(hit & np.isfinite(R).all(axis=(1, 2)))
    return Measurements(
        z=z[keep], R=R[keep], classes=[classes[i] for i in keep], conf=conf[keep], boxes=boxes[keep], index=keep
    )


def _cast(
    spec: CameraSpec, pose: CameraPose, pixels: FloatArray, plane_down: FloatArray
) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Ground points of pixels on per-pixel planes, the 2×2 Jacobian d(north, east)/d(u, v), and which hit."""
    n = len(pixels)
    z = np.full((n, 2), np.nan)
    J = np.full((n, 2, 2), np.nan)
    hit = np.zeros(n, dtype=bool)
    for level in np.unique(plane_down):  # one level per class height: usually one or two
        rows = np.flatnonzero(plane_down == level)
        stacked = np.concatenate([pixels[rows], pixels[rows] + [1.0, 0.0], pixels[rows] + [0.0, 1.0]])
        ground, ok = ground_points(spec, pose, stacked, float(level))
        k = len(rows)
        base, du, dv = ground[:k], ground[k : 2 * k], ground[2 * k :]
        z[rows] = base
        J[rows, :, 0] = du - base
        J[rows, :, 1] = dv - base
        hit[rows] = ok[:k] & ok[k : 2 * k] & ok[2 * k :]
    return z, J, hit


def ego_covariance(noise: NoiseModel, health: SensorHealth) -> FloatArray:
    """The 3×3 NED covariance of the aircraft's absolute position (GPS horizontally, barometer vertically)."""
    h = (noise.gps_sigma_m * health.factor("gps")) ** 2
    v = (noise.vertical_sigma_m * max(health.factor("baro"), health.factor("gps"))) ** 2
    return np.diag([h, h, v])


def common_covariance(noise: NoiseModel, health: SensorHealth, pose: CameraPose, points: FloatArray) -> FloatArray:
    """The slowly varying errors to add to the covariance of objects at ground ``points`` (N×2), which the tracker's
    ``R`` leaves out: the aircraft's position error, and two that scale with a point's offset from the nadir
    (along it): the aircraft's height error (``offset·δh/h``) and the object's unknown posture (its box centre
    ``centre_height_sigma_m`` off the assumed height: ``offset·δc/h``)."""
    cov = ego_covariance(noise, health)
    out = np.zeros((len(points), 2, 2))
    out[:, 0, 0] = cov[0, 0]
    out[:, 1, 1] = cov[1, 1]
    height = max(noise.ground_down_m - pose.down_m, 1e-3)
    offset = points - np.array([pose.north_m, pose.east_m])
    radial = (cov[2, 2] + noise.centre_height_sigma_m**2) / height**2
    out += np.einsum("ni,nj->nij", offset, offset) * radial
    return out
