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

from agentic_core.contracts.trusted import AllFields, record_maker
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

_new_object = record_maker(WorldObject)
_new_pose = record_maker(GeoPose)
_new_velocity = record_maker(Velocity)
_new_relation = record_maker(Relation)

ObjectRow = tuple[str, str, list[float], float, float, float, float, list[float], int, float, TrackState, float]
"""One object's values, as :func:`trusted_objects` takes them: id, class, [north, east, v_north, v_east], lat, lon,
speed, conf, covariance [nn, ne, en, ee], track age (frames), stationary_s, state, last_seen."""


def trusted_objects(rows: Iterable[ObjectRow], *, down: float, alt: float) -> list[WorldObject]:
    """:class:`WorldObject` records, with their pose and velocity, from rows of values that already are what
    validating them would give (see the notes above; ``down`` and ``alt`` are every pose's: the ground plane's)."""
    new_object, new_pose, new_velocity = _new_object, _new_pose, _new_velocity
    return [
        new_object(
            {
                "id": ident,
                "class_name": cls,
                "pose": new_pose({"north": n, "east": e, "down": down, "lat": lat, "lon": lon, "alt": alt}),
                "vel": new_velocity({"north": vn, "east": ve, "down": 0.0, "speed": speed}),
                "conf": conf,
                "cov": ((c00, c01), (c10, c11)),
                "track_age_frames": age,
                "stationary_s": still,
                "state": state,
                "last_seen": seen,
            }
        )
        for ident, cls, (n, e, vn, ve), lat, lon, speed, conf, (c00, c01, c10, c11), age, still, state, seen in rows
    ]


def trusted_relations(rows: Iterable[tuple[str, str, str | None, float | None]]) -> list[Relation]:
    """:class:`Relation` records from ``(subj, pred, obj, value)`` rows that already are what validating them would
    give (see the notes above; a frame has about as many relations as objects)."""
    new_relation = _new_relation
    return [new_relation({"subj": subj, "pred": pred, "obj": obj, "value": value}) for subj, pred, obj, value in rows]


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
