"""The published World Model is built without validating each record again; it is the validated one all the same.

:meth:`Perception.contract` makes the per-object and per-relation records from the tracker's arrays after one
vectorised check of the contract's bounds (:func:`.world_model.trusted_objects`); ``validate=True`` builds the same
contract through pydantic validation, record by record. On real frames the two must agree in every field, in the
type of every value (a float is a ``float``, a covariance a tuple of tuples), in ``model_fields_set`` and in JSON.
"""

from __future__ import annotations

import copy
import json
import math
import pickle
from dataclasses import replace
from typing import Any

import jsonschema
import numpy as np
import pytest
from pydantic import BaseModel, ValidationError

from agentic_core.perception.pipeline import Perception, PerceptionConfig
from agentic_core.perception.scene_graph import Rel
from agentic_core.perception.tracker import TENTATIVE
from agentic_core.perception.world_model import (
    AllFields,
    GeoPose,
    Relation,
    Velocity,
    WorldModel,
    WorldObject,
    world_model_schema,
)
from flight.camera import CameraPose, SensorHealth

from .synthetic import SyntheticScene, run

HOME = (21.4133, 39.8933, 300.0)
LANDMARKS = [
    {"id": "Exit-3", "kind": "exit", "north": 6.0, "east": -4.0},
    {"id": "Shade", "kind": "zone", "polygon": [[-8, -8], [0, -8], [0, 0], [-8, 0]]},
    {"id": "Aid-1", "kind": "first_aid", "circle": {"center": {"north": 8.0, "east": 12.0}, "radius_m": 3.0}},
]


def shape(value: Any) -> Any:
    """A record as nested plain data with the type of every leaf, and every record's fields-set beside it."""
    if isinstance(value, BaseModel):
        fields = {name: shape(v) for name, v in value.__dict__.items()}
        return (type(value).__name__, sorted(value.model_fields_set), fields)
    if isinstance(value, list | tuple):
        return (type(value).__name__, [shape(v) for v in value])
    return (type(value).__name__, value)


def frames(*, health: SensorHealth, moving: bool) -> Any:
    scene = SyntheticScene(seed=11, walkers=12, still=8, false_per_frame=1.0, health=health)
    velocity = (2.0, 0.5) if moving else (0.0, 0.0)  # a moving drone loses tracks out of sight
    yield from run(scene, 90, pose=CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0), drone_velocity=velocity)


@pytest.mark.parametrize(
    ("health", "moving", "tentative"),
    [
        (SensorHealth(), False, False),
        (SensorHealth(degraded={"gps": 3.0, "camera": 1.5}), True, True),
    ],
)
def test_the_published_contract_is_the_validated_one(health: SensorHealth, moving: bool, tentative: bool) -> None:
    perception = Perception(home=HOME, landmarks=LANDMARKS, config=PerceptionConfig(publish_tentative=tentative))
    validator = jsonschema.Draft202012Validator(world_model_schema())
    preds: set[str] = set()
    states: set[str] = set()
    for k, (frame, detections, _) in enumerate(frames(health=health, moving=moving)):
        world = perception.update(frame, detections)
        assert perception.tracks is not None
        reference = perception.contract(frame, perception.tracks, perception.scene_graph.relations, validate=True)
        assert world == reference
        assert shape(world) == shape(reference), k
        assert world.model_dump_json() == reference.model_dump_json()
        assert world.model_dump(exclude_unset=True) == reference.model_dump(exclude_unset=True)
        if k % 15 == 0:
            data = json.loads(world.to_json())
            validator.validate(data)
            assert WorldModel.model_validate(data) == world
        preds |= {r.pred for r in world.relations}
        states |= {o.state for o in world.objects}
    assert {"near", "stationary", "inside"} <= preds  # the frames exercised the relations
    assert states >= ({"confirmed", "tentative"} if tentative else {"confirmed"})
    assert not moving or "lost" in states


def test_a_value_out_of_contract_is_still_refused() -> None:
    """The vectorised check guards the unvalidated path: a NaN (or a latitude off the globe) falls back to
    validation, which refuses it as it always did."""
    perception = Perception(home=HOME)
    for frame, detections, _ in run(SyntheticScene(seed=3, walkers=3, still=3), 10):
        perception.update(frame, detections)
    tracks, relations = perception.tracks, perception.scene_graph.relations
    assert tracks is not None
    shown = int(np.flatnonzero(tracks.state != TENTATIVE)[0])  # a track the contract lists
    perception.contract(frame, tracks, relations)  # as it is: fine

    bad_x = tracks.x.copy()
    bad_x[shown, 2] = math.nan  # a velocity
    with pytest.raises(ValidationError, match="finite"):
        perception.contract(frame, replace(tracks, x=bad_x), relations)
    bad_conf = tracks.conf.copy()
    bad_conf[shown] = math.inf
    with pytest.raises(ValidationError):
        perception.contract(frame, replace(tracks, conf=bad_conf), relations)
    with pytest.raises(ValidationError):
        perception.contract(frame, tracks, [*relations, Rel(tracks.ids[0], "near", "Exit-3", math.nan)])
    # values of another type than validation gives are validated (and converted), not trusted
    extra = [*relations, Rel(tracks.ids[shown], "near", "Exit-3", 2)]
    converted = perception.contract(frame, tracks, extra).relations[-1]
    assert (
        type(converted.value) is float
        and converted == perception.contract(frame, tracks, extra, validate=True).relations[-1]
    )
    near_pole = Perception(home=(89.99999, 0.0, 0.0))
    far_north = tracks.x.copy()
    far_north[:, 0] = 5000.0
    with pytest.raises(ValidationError, match="less than or equal to 90"):
        near_pole.contract(frame, replace(tracks, x=far_north), relations)


@pytest.mark.parametrize("cls", [WorldObject, GeoPose, Velocity, Relation])
def test_the_records_have_nothing_the_unvalidated_path_would_skip(cls: type[BaseModel]) -> None:
    """Records made without validation skip validators, private attributes and ``model_post_init``: the contract's
    records must have none (add one, and this fails: build that record through validation instead)."""
    decorators = cls.__pydantic_decorators__
    assert not (decorators.validators or decorators.field_validators or decorators.model_validators)
    assert not decorators.root_validators
    assert not cls.__private_attributes__ and not cls.__pydantic_post_init__ and not cls.__pydantic_root_model__
    assert cls.model_config.get("extra") == "forbid"


def test_the_shared_fields_set_behaves_as_its_own_until_someone_changes_it() -> None:
    perception = Perception(home=HOME)
    for frame, detections, _ in run(SyntheticScene(seed=4, walkers=2, still=2, false_per_frame=0.0), 8):
        world = perception.update(frame, detections)
    first, second = world.objects[0], world.objects[1]
    assert isinstance(first.model_fields_set, AllFields) and first.model_fields_set == set(WorldObject.model_fields)

    second.conf = 0.5  # assigning a field adds a name already there: no change
    assert second.conf == 0.5 and first.model_fields_set == set(WorldObject.model_fields)
    changed = first.model_copy(update={"conf": 0.25})
    assert changed.conf == 0.25 and type(changed.model_fields_set) is set
    for clone in (copy.deepcopy(world), pickle.loads(pickle.dumps(world))):
        assert clone == world and type(clone.objects[0].model_fields_set) is set
    with pytest.raises(TypeError, match="shared"):
        first.model_fields_set.discard("conf")
    with pytest.raises(TypeError, match="shared"):
        first.pose.model_fields_set.add("colour")
    assert first.model_fields_set.copy() == set(WorldObject.model_fields)


def test_an_empty_frame_and_a_crowd_without_relations() -> None:
    perception = Perception(home=HOME)
    frame, _, _ = next(iter(run(SyntheticScene(seed=1, walkers=1, still=0), 1)))
    world = perception.update(frame, [])
    assert world.objects == [] and world.relations == []
    assert perception.tracks is not None
    assert world == perception.contract(frame, perception.tracks, [], validate=True)
    assert np.isfinite(world.ego_pose.alt)
