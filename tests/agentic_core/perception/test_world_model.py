"""The World Model Contract: its JSON validates against its schema, it is queryable, missions can read it."""

from __future__ import annotations

import json

import jsonschema
import pytest
from pydantic import ValidationError

from agentic_core.mission.expressions import Expression
from agentic_core.mission.functions import find, get_field
from agentic_core.mission.templates import render
from agentic_core.perception.pipeline import Perception
from agentic_core.perception.world_model import SCHEMA_FILE, WorldModel, world_model_schema

from .synthetic import SyntheticScene, run

REGENERATE = "agentic-uav schema world-model > agentic_core/perception/world_model.schema.json"
HOME = (21.4133, 39.8933, 300.0)


def sample_world() -> WorldModel:
    pose = {"north": 0.0, "east": 0.0, "down": 0.0, "lat": 21.4133, "lon": 39.8933, "alt": 300.0}
    return WorldModel.model_validate(
        {
            "timestamp": 12.5,
            "frame": 375,
            "ego_pose": {**pose, "down": -30.0, "alt": 330.0},
            "objects": [
                {
                    "id": "P-12",
                    "class": "person",
                    "conf": 0.89,
                    "stationary_s": 11.2,
                    "track_age_frames": 400,
                    "pose": {**pose, "north": 150.0, "east": 14.0, "lat": 21.41465, "lon": 39.89344},
                },
                {
                    "id": "P-13",
                    "class": "person",
                    "conf": 0.8,
                    "stationary_s": 12.0,
                    "pose": {**pose, "north": 20.0, "east": -10.0},
                },
                {
                    "id": "P-14",
                    "class": "person",
                    "conf": 0.8,
                    "stationary_s": 1.0,
                    "pose": {**pose, "north": 60.0, "east": 20.0},
                },
                {
                    "id": "V-01",
                    "class": "vehicle",
                    "conf": 0.9,
                    "stationary_s": 30.0,
                    "pose": {**pose, "north": -60.0, "east": -38.0},
                },
            ],
            "relations": [
                {"subj": "P-12", "pred": "isolated_from", "obj": "crowd", "value": 21.0},
                {"subj": "P-12", "pred": "stationary", "value": 11.2},
                {"subj": "P-14", "pred": "isolated_from", "obj": "crowd"},
                {"subj": "P-13", "pred": "near", "obj": "Exit-3", "value": 4.0},
                {"subj": "V-01", "pred": "isolated_from", "obj": "crowd"},
            ],
            "health": {"degraded_sensors": ["thermal"], "factors": {"thermal": 2.0}},
        }
    )


def test_the_mission_trigger_finds_the_collapsed_person() -> None:
    world = sample_world()
    found = find(world, class_="person", stationary_s__gte=10, relation="isolated_from")
    assert [o.id for o in found] == ["P-12"]  # P-13 is still but not isolated, P-14 isolated but moving, V-01 a car
    trigger = Expression.parse(
        "find(world, class_='person', stationary_s__gte=params.still_s, relation='isolated_from')"
    )
    event = trigger.evaluate({"world": world, "params": {"still_s": 10}})[0]
    args = render(
        {
            "target_id": "${event.id}",
            "subject": "Collapsed pilgrim at ${event.pose.lat}, ${event.pose.lon}",
            "body": "motionless for ${event.stationary_s} s",
        },
        {"event": event},
    )
    assert args == {
        "target_id": "P-12",
        "subject": "Collapsed pilgrim at 21.41465, 39.89344",
        "body": "motionless for 11.2 s",
    }
    assert get_field(event, "class") == "person"


def test_queries() -> None:
    world = sample_world()
    assert [o.id for o in world.objects_of("person")] == ["P-12", "P-13", "P-14"]
    assert [o.id for o in world.within(0.0, 0.0, 30.0)] == ["P-13"]
    assert [o.id for o in world.within(0.0, 0.0, 100.0, class_="vehicle")] == ["V-01"]
    assert [o.id for o in world.with_relation("isolated_from")] == ["P-12", "P-14", "V-01"]
    assert [o.id for o in world.with_relation("near", "Exit-3")] == ["P-13"]
    assert world.get("P-12") is not None and world.get("P-99") is None
    assert world.has("P-12", "stationary") and not world.has("P-13", "stationary")
    assert world.objects[0].sigma_m == pytest.approx(1.0)


def test_contract_json_validates_against_its_schema() -> None:
    validator = jsonschema.Draft202012Validator(world_model_schema())
    validator.validate(json.loads(sample_world().to_json()))
    perception = Perception(home=HOME)
    for frame, detections, _ in run(SyntheticScene(seed=5), 20):
        world = perception.update(frame, detections)
    data = json.loads(world.to_json())
    assert data["objects"] and data["relations"] and "class" in data["objects"][0]
    validator.validate(data)
    assert WorldModel.model_validate(data) == world  # the JSON round-trips


def test_the_schema_refuses_what_the_model_refuses() -> None:
    validator = jsonschema.Draft202012Validator(world_model_schema())
    good = sample_world().to_dict()
    for path, bad in ((("objects", 0, "conf"), 1.5), (("objects", 0, "cov"), [[1.0, 0.0]]), (("frame",), -1)):
        data = json.loads(json.dumps(good))
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = bad
        assert not validator.is_valid(data), path
        with pytest.raises(ValidationError):
            WorldModel.model_validate(data)
    data = json.loads(json.dumps(good))
    data["objects"][0]["colour"] = "white"
    assert not validator.is_valid(data)


def test_shipped_schema_is_current() -> None:
    shipped = SCHEMA_FILE.read_text(encoding="utf-8")
    assert shipped == json.dumps(world_model_schema(), indent=2) + "\n", f"out of date; regenerate: {REGENERATE}"
