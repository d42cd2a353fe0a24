"""The aircraft's gimballed camera: where a simulated vehicle's camera is (:func:`pose_of`), with the camera's
contracts (:mod:`agentic_core.contracts.camera`) and pinhole geometry (:mod:`agentic_core.contracts.pinhole`)
re-exported for the flight modules that import them from here.

>>> from agentic_core.contracts import pinhole
>>> project_points is pinhole.project_points
True
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from agentic_core.contracts.camera import (
    BoundingBox,
    CameraPose,
    CameraSpec,
    Detection,
    Detector,
    Frame,
    SensorHealth,
)
from agentic_core.contracts.pinhole import (
    BoolArray,
    FloatArray,
    footprint,
    ground_points,
    ground_sample_distance,
    project_points,
    rotation_world_from_camera,
)

if TYPE_CHECKING:
    from flight.sim.simulator import VehicleState


def pose_of(state: VehicleState) -> CameraPose:
    """The camera pose of a simulated vehicle (the camera sits at the aircraft's centre)."""
    return CameraPose(
        north_m=state.north_m,
        east_m=state.east_m,
        down_m=state.down_m,
        roll_rad=state.roll_rad,
        pitch_rad=state.pitch_rad,
        yaw_rad=state.yaw_rad,
    )


__all__ = [
    "BoolArray",
    "BoundingBox",
    "CameraPose",
    "CameraSpec",
    "Detection",
    "Detector",
    "FloatArray",
    "Frame",
    "SensorHealth",
    "footprint",
    "ground_points",
    "ground_sample_distance",
    "pose_of",
    "project_points",
    "rotation_world_from_camera",
]
