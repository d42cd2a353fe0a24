"""The camera's pinhole geometry: world points to pixels and pixels back to the ground, for any camera pose.

A contract because both sides use it: the simulator's detector (``flight``) and perception (``agentic_core``).

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

import numpy as np
from numpy.typing import NDArray

from .camera import CameraPose, CameraSpec

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

# Camera axes (right, down-the-image, optical) expressed in the mount's forward/right/down axes.
_CAMERA_TO_MOUNT = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


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


__all__ = [
    "BoolArray",
    "FloatArray",
    "footprint",
    "ground_points",
    "ground_sample_distance",
    "project_points",
    "rotation_world_from_camera",
]
