"""The World Model Contract (paper §3, Perception output): what perception publishes each frame.

Every object carries a calibrated uncertainty (``conf`` and a position covariance ``cov``), the tracker's
bookkeeping (``track_age_frames``, ``stationary_s``, ``state``) and a pose both in local north/east/down metres and
in latitude/longitude. Relations are ``subj pred obj`` triples with an optional numeric ``value``. Perception
(:mod:`agentic_core.perception`) builds it; missions, reasoners and reports read it.

>>> world = WorldModel.model_validate({
...     "timestamp": 12.5, "frame": 375,
...     "ego_pose": {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30},
...     "objects": [{"id": "P-12", "class": "person", "conf": 0.89,
...                  "pose": {"north": 5, "east": -3, "down": 0, "lat": 21.41335, "lon": 39.89327, "alt": 0}}]})
>>> [o.id for o in world.within(0.0, 0.0, radius_m=10.0)], world.to_dict()["objects"][0]["class"]
(['P-12'], 'person')
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

Finite = Annotated[float, Field(allow_inf_nan=False)]
# Matrices are tuples of rows (JSON: arrays of arrays): immutable, and tuples of floats cost the garbage collector
# nothing, which matters at a thousand objects a frame.
Row2 = tuple[Finite, Finite]
Row3 = tuple[Finite, Finite, Finite]
Cov2 = Annotated[tuple[Row2, Row2], Field(description="2×2 covariance, m² (north, east)")]
Cov3 = Annotated[tuple[Row3, Row3, Row3], Field(description="3×3 covariance, m² (north, east, down)")]
TrackState = Literal["tentative", "confirmed", "lost"]

PREDICATES = ("near", "isolated_from", "inside", "moving_toward", "stationary")
"""The relations perception computes (see :mod:`agentic_core.perception.scene_graph` for their definitions)."""


class Contract(BaseModel):
    """Base of the contract's records: unknown fields are errors, names may be given by field name or alias."""

    model_config = ConfigDict(extra="forbid", populate_by_name=True)


class GeoPose(Contract):
    """A position in local NED metres from home and in WGS-84 degrees and metres (the same point twice)."""

    north: Finite = Field(description="metres north of home")
    east: Finite = Field(description="metres east of home")
    down: Finite = Field(description="metres below home (negative is up)")
    lat: Finite = Field(ge=-90, le=90, description="latitude, degrees")
    lon: Finite = Field(ge=-180, le=180, description="longitude, degrees")
    alt: Finite = Field(description="altitude, metres (home's altitude minus down)")


class Velocity(Contract):
    """A velocity over the ground, m/s, and its magnitude."""

    north: Finite = 0.0
    east: Finite = 0.0
    down: Finite = 0.0
    speed: Finite = Field(default=0.0, ge=0, description="horizontal speed, m/s")


class EgoPose(GeoPose):
    """Where the aircraft (its camera) is, which way it faces, and how sure it is of its position."""

    roll_deg: Finite = 0.0
    pitch_deg: Finite = 0.0
    yaw_deg: Finite = Field(default=0.0, description="heading, 0 north, clockwise")
    cov: Cov3 = Field(
        default=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 4.0)),
        description="position covariance, m² (north, east, down)",
    )


class WorldObject(Contract):
    """One tracked object: a person, a vehicle, ... with its estimated state and how sure perception is of it.

    ``stationary_s`` is how long the object has been observed motionless, counted from its first observation
    (a track born still starts its clock at its first frame; observation gaps at the same spot do not reset it).
    """

    id: str = Field(description="track id, a class letter and a number: P-12, V-01")
    class_name: str = Field(alias="class", description="person, vehicle, ...")
    pose: GeoPose
    vel: Velocity = Field(default_factory=Velocity)
    conf: Finite = Field(ge=0, le=1, description="detection confidence, smoothed over the track")
    cov: Cov2 = Field(default=((1.0, 0.0), (0.0, 1.0)), description="position covariance, m²")
    track_age_frames: int = Field(default=1, ge=0, description="frames since the track's first detection")
    stationary_s: Finite = Field(default=0.0, ge=0, description="seconds observed motionless")
    state: TrackState = Field(default="confirmed", description="tentative, confirmed, or lost (not seen lately)")
    last_seen: Finite = Field(default=0.0, description="timestamp of the last detection on this track")

    @property
    def sigma_m(self) -> float:
        """One-sigma horizontal position uncertainty (m): the root of the covariance's largest eigenvalue."""
        (a, b), (_, d) = self.cov
        return math.sqrt(max(0.0, (a + d) / 2.0 + math.sqrt(((a - d) / 2.0) ** 2 + b * b)))


class Relation(Contract):
    """A ``subj pred obj`` triple: ``P-12 near Exit-3``; unary predicates (``stationary``) have no object."""

    subj: str
    pred: str = Field(description="near, isolated_from, inside, moving_toward, stationary, ...")
    obj: str | None = None
    value: Finite | None = Field(default=None, description="the measure behind it: metres, seconds, degrees")


class Health(Contract):
    """Which sensors are degraded and by how much their noise grows (covariances are inflated accordingly)."""

    degraded_sensors: list[str] = Field(default_factory=list)
    factors: dict[str, Finite] = Field(default_factory=dict, description="noise factor (>= 1) per degraded sensor")


class Landmark(Contract):
    """A known place in the scene: an exit, a first-aid post, a zone (polygon or circle)."""

    id: str
    kind: str = "landmark"
    north: Finite
    east: Finite
    lat: Finite | None = Field(default=None, ge=-90, le=90)
    lon: Finite | None = Field(default=None, ge=-180, le=180)
    radius_m: Finite | None = Field(default=None, gt=0, description="a circular zone")
    polygon: list[Row2] | None = Field(default=None, description="a zone's corners, [north, east] metres")


class WorldModel(Contract):
    """The world as perception sees it at one instant: what mission triggers, the reasoner and reports read."""

    timestamp: Finite = Field(description="simulation time, seconds")
    frame: int = Field(default=0, ge=0, description="camera frame index")
    ego_pose: EgoPose
    objects: list[WorldObject] = Field(default_factory=list)
    relations: list[Relation] = Field(default_factory=list)
    health: Health = Field(default_factory=Health)
    landmarks: list[Landmark] = Field(default_factory=list)

    # ---- queries (plain methods: mission expressions see only the fields) ----

    def get(self, object_id: str) -> WorldObject | None:
        """The object with this id, or ``None``."""
        return next((o for o in self.objects if o.id == object_id), None)

    def objects_of(self, class_: str, *, states: Iterable[TrackState] | None = None) -> list[WorldObject]:
        """The objects of one class (``"person"``), optionally only those in the given track states."""
        wanted = None if states is None else set(states)
        return [o for o in self.objects if o.class_name == class_ and (wanted is None or o.state in wanted)]

    def within(self, north: float, east: float, radius_m: float, *, class_: str | None = None) -> list[WorldObject]:
        """The objects (of one class, if given) within ``radius_m`` horizontally of a local north/east point."""
        return [
            o
            for o in self.objects
            if (class_ is None or o.class_name == class_)
            and math.hypot(o.pose.north - north, o.pose.east - east) <= radius_m
        ]

    def with_relation(self, pred: str, obj: str | None = None) -> list[WorldObject]:
        """The objects that are the subject of a ``pred`` relation (to ``obj``, if given)."""
        subjects = {r.subj for r in self.relations if r.pred == pred and (obj is None or r.obj == obj)}
        return [o for o in self.objects if o.id in subjects]

    def relations_of(self, object_id: str) -> list[Relation]:
        """Every relation whose subject is this object."""
        return [r for r in self.relations if r.subj == object_id]

    def has(self, object_id: str, pred: str, obj: str | None = None) -> bool:
        """Whether the relation ``object_id pred [obj]`` holds."""
        return any(r.subj == object_id and r.pred == pred and (obj is None or r.obj == obj) for r in self.relations)

    # ---- serialisation (the contract's JSON uses the alias "class") ----

    def to_dict(self) -> dict[str, Any]:
        """The contract as JSON-ready data, ``class`` spelt as in the paper."""
        return self.model_dump(mode="json", by_alias=True)

    def to_json(self, indent: int | None = None) -> str:
        """The contract as JSON text (what alerts attach and runs store)."""
        return self.model_dump_json(by_alias=True, indent=indent)


def world_model_schema() -> dict[str, Any]:
    """The JSON Schema of the World Model Contract, generated from :class:`WorldModel`."""
    schema = WorldModel.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "agentic-uavs World Model Contract"
    return schema


__all__ = [
    "PREDICATES",
    "Contract",
    "Cov2",
    "Cov3",
    "EgoPose",
    "Finite",
    "GeoPose",
    "Health",
    "Landmark",
    "Relation",
    "Row2",
    "Row3",
    "TrackState",
    "Velocity",
    "WorldModel",
    "WorldObject",
    "world_model_schema",
]
