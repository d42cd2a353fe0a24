"""The aircraft's gimballed camera: its geometry, the frames it takes and the detection contract.

One pinhole model serves both directions: the simulated detector projects the scene's actors into pixel boxes
(:func:`project_points`), and perception casts a detection's pixel back onto the ground (:func:`ground_points`).
Positions are local north/east/down metres from home (the simulator's frame); the ground is a plane at
``ground_down_m`` (0: the home's ground level).

Frames: the camera looks along its optical axis ``z``, with ``x`` to the image's right and ``y`` down the image.
Mounted level and facing forward, that is the aircraft's forward, right and down. The gimbal pitches it down
(``gimbal_pitch_deg=-90`` looks straight down, the top of the image towards the aircraft's nose); a stabilised
gimbal (the default) cancels the aircraft's roll and pitch and follows its heading.

>>> spec = CameraSpec()
>>> pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0, yaw_rad=0.0)
>>> pixels, visible = project_points(spec, pose, np.array([[10.0, 0.0, 0.0]]))
>>> bool(visible[0]), round(float(pixels[0, 0])), pixels[0, 1] < spec.height_px / 2  # 10 m north: image top
(True, 960, np.True_)
>>> ground, hit = ground_points(spec, pose, pixels)
>>> np.round(ground[0], 6).tolist()
[10.0, 0.0]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

if TYPE_CHECKING:
    from flight.sim.simulator import VehicleState

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

# Camera axes (right, down-the-image, optical) expressed in the mount's forward/right/down axes.
_CAMERA_TO_MOUNT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


class CameraSpec(BaseModel):
    """What the camera is: field of view, resolution, frame rate and how its gimbal points it.

    The defaults are a typical small-drone camera (84° horizontal field of view, 1920×1080 at 30 Hz) looking
    straight down from a stabilised gimbal, as a search pattern flies it.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    hfov_deg: float = Field(default=84.0, gt=1.0, lt=179.0, description="horizontal field of view")
    width_px: int = Field(default=1920, ge=16)
    height_px: int = Field(default=1080, ge=16)
    rate_hz: float = Field(default=30.0, gt=0.0, description="frames per second")
    gimbal_pitch_deg: float = Field(default=-90.0, ge=-90.0, le=30.0, description="-90 looks straight down")
    stabilized: bool = Field(default=True, description="the gimbal cancels the aircraft's roll and pitch")

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels)."""
        return (self.width_px / 2.0) / math.tan(math.radians(self.hfov_deg) / 2.0)

    @property
    def vfov_deg(self) -> float:
        """Vertical field of view, from the horizontal one and the aspect ratio."""
        return math.degrees(2.0 * math.atan((self.height_px / 2.0) / self.focal_px))

    @property
    def principal_point(self) -> tuple[float, float]:
        """The image centre (pixels)."""
        return self.width_px / 2.0, self.height_px / 2.0

    @property
    def frame_period_s(self) -> float:
        return 1.0 / self.rate_hz


class CameraPose(BaseModel):
    """Where the camera is and which way the aircraft carrying it faces (local NED metres, radians)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    north_m: float
    east_m: float
    down_m: float = Field(description="negative above home: 30 m up is -30")
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = Field(default=0.0, description="heading, 0 north, clockwise")

    @classmethod
    def from_vehicle(cls, state: VehicleState) -> CameraPose:
        """The camera pose of a simulated vehicle (the camera sits at the aircraft's centre)."""
        return cls(
            north_m=state.north_m,
            east_m=state.east_m,
            down_m=state.down_m,
            roll_rad=state.roll_rad,
            pitch_rad=state.pitch_rad,
            yaw_rad=state.yaw_rad,
        )

    @property
    def position(self) -> FloatArray:
        return np.array([self.north_m, self.east_m, self.down_m])


class SensorHealth(BaseModel):
    """How well the sensors behind a frame are doing; perception inflates its covariances accordingly.

    ``degraded`` names the sensors in trouble (``"gps"``, ``"thermal"``, ``"camera"``), each with a factor >= 1 by
    which that sensor's noise grows (``{"gps": 4.0}``: GPS errors four times their nominal size).
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    degraded: dict[str, float] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _factors_at_least_one(self) -> SensorHealth:
        bad = [name for name, factor in self.degraded.items() if not factor >= 1.0]
        if bad:
            raise ValueError(f"degradation factors must be >= 1: {', '.join(bad)}")
        return self

    def factor(self, sensor: str) -> float:
        """The noise factor of one sensor, 1.0 when it is healthy."""
        return self.degraded.get(sensor, 1.0)

    @property
    def ok(self) -> bool:
        return not self.degraded


class BoundingBox(BaseModel):
    """An axis-aligned pixel box; ``x`` grows rightwards and ``y`` downwards from the image's top-left corner."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    x_min: float
    y_min: float
    x_max: float
    y_max: float

    @model_validator(mode="after")
    def _ordered(self) -> BoundingBox:
        if not (self.x_min <= self.x_max and self.y_min <= self.y_max):
            raise ValueError(f"box corners out of order: ({self.x_min}, {self.y_min}) ({self.x_max}, {self.y_max})")
        return self

    @property
    def center(self) -> tuple[float, float]:
        return (self.x_min + self.x_max) / 2.0, (self.y_min + self.y_max) / 2.0

    @property
    def width(self) -> float:
        return self.x_max - self.x_min

    @property
    def height(self) -> float:
        return self.y_max - self.y_min


class Detection(BaseModel):
    """One object a detector found in one frame: its class, pixel box and confidence.

    ``truth_id`` is the simulated actor the detection came from (``None`` for a false positive or a real
    detector); it exists only so evaluation can score against ground truth, and perception never reads it.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    class_name: str = Field(alias="class", description="person, vehicle, ...")
    box: BoundingBox
    confidence: float = Field(ge=0.0, le=1.0)
    truth_id: str | None = None


@dataclass(frozen=True)
class Frame:
    """One camera frame: when and from where it was taken, the sensors' health, and the image if there is one.

    The simulated camera has no pixels (``image`` is ``None``); a real detector reads ``image`` (H×W×3, uint8).
    """

    index: int
    time_s: float
    spec: CameraSpec
    pose: CameraPose
    health: SensorHealth = field(default_factory=SensorHealth)
    image: NDArray[np.uint8] | None = None


@runtime_checkable
class Detector(Protocol):
    """Anything that turns a frame into detections: the simulated detector, or a real model the user plugs in."""

    def detect(self, frame: Frame) -> list[Detection]: ...


def rotation_world_from_camera(spec: CameraSpec, pose: CameraPose) -> FloatArray:
    """The 3×3 rotation taking camera axes (right, image-down, optical) to north/east/down."""
    gimbal = math.radians(spec.gimbal_pitch_deg)
    if spec.stabilized:
        mount = _rz(pose.yaw_rad) @ _ry(gimbal)
    else:
        mount = _rz(pose.yaw_rad) @ _ry(pose.pitch_rad) @ _rx(pose.roll_rad) @ _ry(gimbal)
    rotation: FloatArray = mount @ _CAMERA_TO_MOUNT
    return rotation


def project_points(spec: CameraSpec, pose: CameraPose, points_ned: FloatArray) -> tuple[FloatArray, BoolArray]:
    """Pixel coordinates (N×2) of N world points (N×3, NED metres), and which of them fall inside the image.

    Points behind the camera get NaN pixels and are not visible.
    """
    points = np.asarray(points_ned, dtype=float).reshape(-1, 3)
    cam = (points - pose.position) @ rotation_world_from_camera(spec, pose)  # R^T (p - c), row-wise
    depth = cam[:, 2]
    in_front = depth > 1e-6
    f = spec.focal_px
    cx, cy = spec.principal_point
    pixels = np.full((len(points), 2), np.nan)
    safe = np.where(in_front, depth, 1.0)
    pixels[:, 0] = np.where(in_front, cx + f * cam[:, 0] / safe, np.nan)
    pixels[:, 1] = np.where(in_front, cy + f * cam[:, 1] / safe, np.nan)
    with np.errstate(invalid="ignore"):
        visible = (
            in_front
            & (pixels[:, 0] >= 0.0)
            & (pixels[:, 0] < spec.width_px)
            & (pixels[:, 1] >= 0.0)
            & (pixels[:, 1] < spec.height_px)
        )
    return pixels, visible


def ground_points(
    spec: CameraSpec, pose: CameraPose, pixels: FloatArray, ground_down_m: float = 0.0
) -> tuple[FloatArray, BoolArray]:
    """North/east (N×2) where the rays through N pixels (N×2) meet the ground plane, and which rays meet it.

    A ray at or above the horizon never meets the ground: its point is NaN and its flag False.
    """
    px = np.asarray(pixels, dtype=float).reshape(-1, 2)
    f = spec.focal_px
    cx, cy = spec.principal_point
    rays = np.column_stack([(px[:, 0] - cx) / f, (px[:, 1] - cy) / f, np.ones(len(px))])
    world = rays @ rotation_world_from_camera(spec, pose).T
    height = ground_down_m - pose.down_m  # how far below the camera the ground is
    descending = world[:, 2] > 1e-9
    t = np.where(descending, height / np.where(descending, world[:, 2], 1.0), np.nan)
    hits = descending & (t > 0.0)
    out = np.full((len(px), 2), np.nan)
    out[hits, 0] = pose.north_m + t[hits] * world[hits, 0]
    out[hits, 1] = pose.east_m + t[hits] * world[hits, 1]
    return out, hits


def footprint(spec: CameraSpec, pose: CameraPose, ground_down_m: float = 0.0) -> FloatArray | None:
    """The image's four corners on the ground (4×2 north/east, clockwise from top-left), or ``None`` when part of
    the image sees sky."""
    corners = np.array([[0.0, 0.0], [spec.width_px, 0.0], [spec.width_px, spec.height_px], [0.0, spec.height_px]])
    ground, hits = ground_points(spec, pose, corners, ground_down_m)
    return ground if bool(hits.all()) else None


def ground_sample_distance(
    spec: CameraSpec, pose: CameraPose, points_ned: FloatArray | Sequence[Sequence[float]]
) -> FloatArray:
    """Metres on the ground per pixel at each of N points (range / focal length): larger is coarser."""
    points = np.asarray(points_ned, dtype=float).reshape(-1, 3)
    gsd: FloatArray = np.linalg.norm(points - pose.position, axis=1) / spec.focal_px
    return gsd


def _rx(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rz(angle: float) -> FloatArray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
