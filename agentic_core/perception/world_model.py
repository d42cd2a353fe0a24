"""The World Model Contract (paper §3, Perception output): what perception publishes each frame.

One pydantic model, its JSON Schema exported from it (:func:`world_model_schema`). Every object carries a
calibrated uncertainty (``conf`` and a position covariance ``cov``), the tracker's bookkeeping
(``track_age_frames``, ``stationary_s``, ``state``) and a pose both in local north/east/down metres and in
latitude/longitude, so mission expressions can measure with either. Relations are ``subj pred obj`` triples
(``near``, ``isolated_from``, ``inside``, ``moving_toward``, ``stationary``) with an optional numeric ``value``.

The model is queryable from Python (:meth:`WorldModel.objects_of`, :meth:`WorldModel.within`,
:meth:`WorldModel.with_relation`, :meth:`WorldModel.get`) and from mission expressions, whose ``find`` reads the
same fields (``class`` is the alias of ``class_name``):

>>> from agentic_core.mission.functions import find
>>> world = WorldModel.model_validate({
...     "timestamp": 12.5, "frame": 375,
...     "ego_pose": {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30},
...     "objects": [{"id": "P-12", "class": "person", "conf": 0.89, "track_age_frames": 400, "stationary_s": 11.2,
...                  "pose": {"north": 5, "east": -3, "down": 0, "lat": 21.41335, "lon": 39.89327, "alt": 0}}],
...     "relations": [{"subj": "P-12", "pred": "isolated_from", "obj": "crowd", "value": 14.0}]})
>>> [o.id for o in find(world, class_="person", stationary_s__gte=10, relation="isolated_from")]
['P-12']
>>> [o.id for o in world.within(0.0, 0.0, radius_m=10.0)], world.get("P-12").class_name
(['P-12'], 'person')
>>> world.to_dict()["objects"][0]["class"]
'person'
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable
from collections.abc import Set as AbstractSet
from pathlib import Path
from typing import Annotated, Any, Literal, Self, cast

from pydantic import BaseModel, ConfigDict, Field

SCHEMA_FILE = Path(__file__).with_name("world_model.schema.json")
"""The shipped copy of :func:`world_model_schema`, kept current by a test; regenerate it with
``python -c "import agentic_core.perception.world_model as m; m.write_schema_file()"``."""

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


# ---- records built without validating them again ----
#
# Perception builds hundreds of objects and relations a frame from its own arrays, after one vectorised check of
# every bound (finite, latitude in range, ...). Validating each of them again cost more than the rest of the
# update together, so they are made as pydantic's ``model_construct`` makes records, without its per-field alias
# and default lookups: ``__dict__`` set to values that are exactly what validation would give (``float`` for every
# float field, not an ``int`` or numpy scalar; tuples for covariances; records for nested records), every field
# given. Tests hold them equal, field by field, in ``model_fields_set`` and in JSON, to validated records on real
# frames, and keep these records free of validators, private attributes and ``model_post_init``, which this skips.


def _slot_setter(name: str) -> Callable[[Any, Any], None]:
    """The setter of one of pydantic's instance slots (``__dict__``, ``__pydantic_fields_set__``, ...), called
    directly: a third faster than ``object.__setattr__``, which looks the slot up through the class every time."""
    slot = vars(BaseModel).get(name)
    setter = getattr(slot, "__set__", None)
    if setter is None:  # not a slot in some pydantic version: set it as model_construct does
        return lambda obj, value: object.__setattr__(obj, name, value)
    return cast("Callable[[Any, Any], None]", setter)


_set_dict = _slot_setter("__dict__")
_set_fields_set = _slot_setter("__pydantic_fields_set__")
_set_extra = _slot_setter("__pydantic_extra__")
_set_private = _slot_setter("__pydantic_private__")
_SHARED = "the fields-set of a record perception built is shared by its class's records: copy it to change it"


class AllFields(set[str]):
    """Every field name of one record class: the ``model_fields_set`` that perception's records share.

    Every record sets every field, so they can share one set instead of allocating one each, which was a third of
    the cost of a record (a set of more than four names allocates a table of its own). It is a ``set``, equal to
    the one validation makes, but it refuses to change, since it is shared: pydantic only ever adds a name already
    in it (on assigning a field: no change), and a copy (``copy()``, ``model_copy``, ``copy.copy``, pickling) is an
    ordinary set.
    """

    def add(self, element: str) -> None:
        if element not in self:
            raise TypeError(_SHARED)

    def update(self, *s: Iterable[str]) -> None:
        if any(element not in self for other in s for element in other):
            raise TypeError(_SHARED)

    def __ior__(self, value: AbstractSet[str]) -> Self:  # type: ignore[override,misc]
        self.update(value)
        return self

    def discard(self, element: object) -> None:
        raise TypeError(_SHARED)

    def remove(self, element: str) -> None:
        raise TypeError(_SHARED)

    def pop(self) -> str:
        raise TypeError(_SHARED)

    def clear(self) -> None:
        raise TypeError(_SHARED)

    def difference_update(self, *s: Iterable[Any]) -> None:
        raise TypeError(_SHARED)

    def intersection_update(self, *s: Iterable[Any]) -> None:
        raise TypeError(_SHARED)

    def symmetric_difference_update(self, s: Iterable[str], /) -> None:
        raise TypeError(_SHARED)

    def __iand__(self, value: AbstractSet[object]) -> Self:
        raise TypeError(_SHARED)

    def __isub__(self, value: AbstractSet[object]) -> Self:
        raise TypeError(_SHARED)

    def __ixor__(self, value: AbstractSet[str]) -> Self:  # type: ignore[override,misc]
        raise TypeError(_SHARED)

    def copy(self) -> set[str]:
        return set(self)

    def __copy__(self) -> set[str]:
        return set(self)

    def __deepcopy__(self, memo: dict[int, Any]) -> set[str]:
        return set(self)

    def __reduce__(self) -> tuple[type[set[str]], tuple[list[str]]]:
        return set, (list(self),)


_OBJECT_FIELDS = AllFields(WorldObject.model_fields)
_POSE_FIELDS = AllFields(GeoPose.model_fields)
_VELOCITY_FIELDS = AllFields(Velocity.model_fields)
_RELATION_FIELDS = AllFields(Relation.model_fields)

ObjectRow = tuple[str, str, list[float], float, float, float, float, list[float], int, float, TrackState, float]
"""One object's values, as :func:`trusted_objects` takes them: id, class, [north, east, v_north, v_east], lat, lon,
speed, conf, covariance [nn, ne, en, ee], track age (frames), stationary_s, state, last_seen."""


def trusted_objects(rows: Iterable[ObjectRow], *, down: float, alt: float) -> list[WorldObject]:
    """:class:`WorldObject` records, with their pose and velocity, from rows of values that already are what
    validating them would give (see the notes above; ``down`` and ``alt`` are every pose's: the ground plane's)."""
    new_object, new_pose, new_velocity = WorldObject.__new__, GeoPose.__new__, Velocity.__new__
    set_dict, set_fields_set, set_extra, set_private = _set_dict, _set_fields_set, _set_extra, _set_private
    out = []
    for ident, cls, (n, e, vn, ve), lat, lon, speed, conf, (c00, c01, c10, c11), age, still, state, seen in rows:
        pose = new_pose(GeoPose)
        set_dict(pose, {"north": n, "east": e, "down": down, "lat": lat, "lon": lon, "alt": alt})
        set_fields_set(pose, _POSE_FIELDS)
        set_extra(pose, None)
        set_private(pose, None)
        vel = new_velocity(Velocity)
        set_dict(vel, {"north": vn, "east": ve, "down": 0.0, "speed": speed})
        set_fields_set(vel, _VELOCITY_FIELDS)
        set_extra(vel, None)
        set_private(vel, None)
        record = new_object(WorldObject)
        set_dict(
            record,
            {
                "id": ident,
                "class_name": cls,
                "pose": pose,
                "vel": vel,
                "conf": conf,
                "cov": ((c00, c01), (c10, c11)),
                "track_age_frames": age,
                "stationary_s": still,
                "state": state,
                "last_seen": seen,
            },
        )
        set_fields_set(record, _OBJECT_FIELDS)
        set_extra(record, None)
        set_private(record, None)
        out.append(record)
    return out


def trusted_relations(rows: Iterable[tuple[str, str, str | None, float | None]]) -> list[Relation]:
    """:class:`Relation` records from ``(subj, pred, obj, value)`` rows that already are what validating them would
    give (see the notes above; a frame has about as many relations as objects)."""
    new_relation = Relation.__new__
    set_dict, set_fields_set, set_extra, set_private = _set_dict, _set_fields_set, _set_extra, _set_private
    out = []
    for subj, pred, obj, value in rows:
        record = new_relation(Relation)
        set_dict(record, {"subj": subj, "pred": pred, "obj": obj, "value": value})
        set_fields_set(record, _RELATION_FIELDS)
        set_extra(record, None)
        set_private(record, None)
        out.append(record)
    return out


def world_model_schema() -> dict[str, Any]:
    """The JSON Schema of the World Model Contract, generated from :class:`WorldModel`."""
    schema = WorldModel.model_json_schema(by_alias=True)
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "agentic-uavs World Model Contract"
    return schema


def write_schema_file() -> None:
    """Write :func:`world_model_schema` to :data:`SCHEMA_FILE` (after changing the contract)."""
    SCHEMA_FILE.write_text(json.dumps(world_model_schema(), indent=2) + "\n", encoding="utf-8")
