"""Perception (paper §3, layer 1): detections → Kalman tracks → 3D semantic scene graph → World Model Contract.

:class:`Perception` runs the whole chain once per camera frame and returns the :class:`WorldModel` that mission
triggers, the reasoner and reports read; its parts are usable alone: :mod:`.measurement` (pixels to ground points
with covariances), :mod:`.tracker` (+ :mod:`.kalman`, :mod:`.association`), :mod:`.scene_graph` (relations and the
networkx graph), :mod:`.world_model` (the contract and its JSON Schema), :mod:`.annotate` (a PNG of a frame for
alerts) and :mod:`.metrics` (scoring tracks against ground truth).

>>> from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame
>>> perception = Perception(home=(21.4133, 39.8933, 300.0))
>>> world = perception.update(Frame(index=0, time_s=0.0, spec=CameraSpec(),
...                                 pose=CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)), [])
>>> world.objects, round(world.ego_pose.alt, 1)
([], 330.0)
"""

from typing import Any

from .measurement import NoiseModel, ground_measurements
from .metrics import TrackingScore
from .pipeline import STAGES, Perception, PerceptionConfig
from .scene_graph import RelationConfig, SceneGraph, as_landmark
from .tracker import Tracker, TrackerConfig, TrackerState, TrackTable
from .world_model import (
    EgoPose,
    GeoPose,
    Health,
    Landmark,
    Relation,
    Velocity,
    WorldModel,
    WorldObject,
    world_model_schema,
)

__all__ = [
    "STAGES",
    "EgoPose",
    "GeoPose",
    "Health",
    "Landmark",
    "NoiseModel",
    "Perception",
    "PerceptionConfig",
    "Relation",
    "RelationConfig",
    "SceneGraph",
    "TrackTable",
    "Tracker",
    "TrackerConfig",
    "TrackerState",
    "TrackingScore",
    "Velocity",
    "WorldModel",
    "WorldObject",
    "annotate_frame",
    "as_landmark",
    "casualties_of",
    "ground_measurements",
    "world_model_schema",
]


def __getattr__(name: str) -> Any:
    """``annotate_frame`` and ``casualties_of`` load matplotlib, so only when first asked for."""
    if name in ("annotate_frame", "casualties_of"):
        from . import annotate

        return getattr(annotate, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
