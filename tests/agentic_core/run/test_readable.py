"""Readable outputs: a track lying on a still, named actor of the scene is linked to it (and only such a track);
labels never double and never touch a longer id; long floats are cut, coordinates kept to 1e-6°."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agentic_core.contracts.geodesy import offset_position
from agentic_core.perception.world_model import WorldModel
from agentic_core.run.readable import TruthLinks, label, link_truth, readable, rounded
from flight.sim.scene_file import load_scene

SCENE = load_scene(Path(__file__).parent / "scenes" / "near_emergency.yaml")


def world_with(*objects: tuple[str, str, float, float]) -> WorldModel:
    """A World Model holding ``(id, class, north, east)`` objects of the test scene."""
    home = SCENE.home
    rows = []
    for object_id, class_name, north, east in objects:
        lat, lon = offset_position(home.lat_deg, home.lon_deg, north, east)
        pose = {"north": north, "east": east, "down": 0.0, "lat": lat, "lon": lon, "alt": home.alt_msl_m}
        rows.append({"id": object_id, "class": class_name, "pose": pose, "conf": 0.9})
    ego = {"north": 0, "east": 0, "down": -30, "lat": home.lat_deg, "lon": home.lon_deg, "alt": 30}
    return WorldModel.model_validate({"timestamp": 1.0, "ego_pose": ego, "objects": rows})


def test_a_track_on_the_casualty_is_linked_and_one_elsewhere_is_not() -> None:
    casualty = SCENE.actor("P-12").position
    world = world_with(
        ("P-1203", "person", casualty.north + 1.0, casualty.east - 1.0),  # the tracker's estimate, a metre off
        ("P-1204", "person", casualty.north + 8.0, casualty.east),  # someone else, 8 m away
        ("V-0007", "vehicle", casualty.north, casualty.east),  # not a person: not the casualty
    )
    assert link_truth(world, SCENE) == {"P-1203": "P-12"}


def test_each_link_is_said_once_in_the_trace() -> None:
    said: list[dict[str, Any]] = []
    links = TruthLinks(SCENE, lambda kind, **fields: said.append({"kind": kind, **fields}))
    casualty = SCENE.actor("P-12").position
    for _ in range(3):
        links.see(world_with(("P-1203", "person", casualty.north, casualty.east)))
    assert dict(links) == {"P-1203": "P-12"}
    assert [(s["object"], s["truth"]) for s in said] == [("P-1203", "P-12")]
    assert readable(said[0]["summary"], links) == said[0]["summary"] == "tracked as P-1203 (scene P-12)"
    assert TruthLinks(None, lambda kind, **fields: None).get("P-1203") is None


def test_labels_do_not_double_or_touch_longer_ids() -> None:
    links = {"P-12": "P-1", "P-1203": "P-12"}
    text = readable("P-1203 near P-12 and P-120; P-1203 (scene P-12) already labelled", links)
    assert text == "P-1203 (scene P-12) near P-12 (scene P-1) and P-120; P-1203 (scene P-12) already labelled"
    assert label("P-12", {"P-12": "P-12"}) == "P-12"  # the same id needs no link


def test_numbers_are_rounded_to_what_they_mean() -> None:
    data = {"aircraft": {"lat_deg": 21.414651123456, "lon_deg": 39.8934333987, "alt_m": 15.8712},
            "subject": {"id": "P-1", "lat": 21.414654914659476, "lon": 39.89343493866723}, "n": 3}  # fmt: skip
    assert rounded(data) == {"aircraft": {"lat_deg": 21.414651, "lon_deg": 39.893433, "alt_m": 15.9},
                             "subject": {"id": "P-1", "lat": 21.414655, "lon": 39.893435}, "n": 3}  # fmt: skip
    assert readable("at 21.41465442152097, 39.89343123897637 (1.5 s)", {}) == "at 21.414654, 39.893431 (1.5 s)"


def test_a_resumed_run_takes_back_the_links_its_trace_published_without_saying_them_again() -> None:
    said: list[dict[str, Any]] = []
    links = TruthLinks(None, lambda kind, **fields: said.append(fields))
    links.remember([
        {"kind": "log", "object": "P-1104", "truth": "P-12", "summary": "tracked as P-1104 (scene P-12)"},
        {"kind": "log", "object": "P-9", "summary": "no truth"},
        {"kind": "decision", "object": "P-7", "truth": "P-3"},  # only the links' own records count
    ])  # fmt: skip
    assert dict(links) == {"P-1104": "P-12"} and said == []
    assert readable("rules on P-1104: critical", links) == "rules on P-1104 (scene P-12): critical"
