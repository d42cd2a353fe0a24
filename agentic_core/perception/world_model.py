"""The World Model Contract (paper §3, Perception output): what perception publishes each frame. The models live
in :mod:`agentic_core.contracts.world_model` (re-exported here); this module builds their records fast and keeps
the shipped schema file.

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
from collections.abc import Iterable
from pathlib import Path

from agentic_core.contracts import trusted
from agentic_core.contracts.trusted import AllFields
from agentic_core.contracts.world_model import (
    PREDICATES,
    Contract,
    Cov2,
    Cov3,
    EgoPose,
    Finite,
    GeoPose,
    Health,
    Landmark,
    Relation,
    Row2,
    Row3,
    TrackState,
    Velocity,
    WorldModel,
    WorldObject,
    world_model_schema,
)

SCHEMA_FILE = Path(__file__).with_name("world_model.schema.json")
"""The shipped copy of :func:`world_model_schema`, kept current by a test; regenerate it with
``python -c "import agentic_core.perception.world_model as m; m.write_schema_file()"``."""

# ---- records built without validating them again ----
#
# Perception builds hundreds of objects and relations a frame from its own arrays, after one vectorised check of
# every bound (finite, latitude in range, ...). Validating each of them again cost more than the rest of the
# update together, so they are built as :mod:`agentic_core.contracts.trusted` says.

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
    set_dict, set_fields_set, set_extra, set_private = (  # locals: looked up once, not per record
        trusted.set_dict,
        trusted.set_fields_set,
        trusted.set_extra,
        trusted.set_private,
    )
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
    set_dict, set_fields_set, set_extra, set_private = (  # locals: looked up once, not per record
        trusted.set_dict,
        trusted.set_fields_set,
        trusted.set_extra,
        trusted.set_private,
    )
    out = []
    for subj, pred, obj, value in rows:
        record = new_relation(Relation)
        set_dict(record, {"subj": subj, "pred": pred, "obj": obj, "value": value})
        set_fields_set(record, _RELATION_FIELDS)
        set_extra(record, None)
        set_private(record, None)
        out.append(record)
    return out


def write_schema_file() -> None:
    """Write :func:`world_model_schema` to :data:`SCHEMA_FILE` (after changing the contract)."""
    SCHEMA_FILE.write_text(json.dumps(world_model_schema(), indent=2) + "\n", encoding="utf-8")


__all__ = [
    "PREDICATES",
    "SCHEMA_FILE",
    "AllFields",
    "Contract",
    "Cov2",
    "Cov3",
    "EgoPose",
    "Finite",
    "GeoPose",
    "Health",
    "Landmark",
    "ObjectRow",
    "Relation",
    "Row2",
    "Row3",
    "TrackState",
    "Velocity",
    "WorldModel",
    "WorldObject",
    "trusted_objects",
    "trusted_relations",
    "world_model_schema",
    "write_schema_file",
]
