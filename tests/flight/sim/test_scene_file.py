"""Scene files: every problem of a wrong file is reported as ``file:line:col: message`` naming the field, never a
traceback; the shipped JSON Schema stays in step with the model."""

import json
import textwrap
from pathlib import Path

import jsonschema
import pytest
import yaml

from flight.sim.scene_file import SceneFileError, SceneProblem, load_scene, save_scene, scene_json_schema
from flight.sim.scene_gen import generate_scene

REPO = Path(__file__).resolve().parents[3]
SCENES = REPO / "scenes"
SCHEMA_FILE = SCENES / "scene.schema.json"
REGENERATE = "agentic-uav schema scene > scenes/scene.schema.json"


def problems_of(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    with pytest.raises(SceneFileError) as info:
        load_scene(path, file=name)
    return [str(p) for p in info.value.problems]


def test_type_errors_and_unknown_fields_name_file_line_and_field(tmp_path):
    problems = problems_of(
        tmp_path,
        """\
        id: bad-one
        zones:
          - id: Z-1
            polygon: [{north: 0, east: 0}, {north: 10, east: 0}, {north: 10, east: 10}]
            density: many
            flow: {heading_deg: 0, sped_mps: 1}
        actors:
          - {id: P-1, position: {north: 0, east: 50}, behaviour: lying}
          - {id: P-2, position: {north: 0, east: 51}, behavior: sitting}
          - {id: P-3, position: {north: 0}}
        """,
    )
    assert problems == [
        "scene.yaml:5:14: zones[0] (Z-1).density: Input should be a valid number, unable to parse string as a number "
        "(got 'many')",
        "scene.yaml:6:28: zones[0] (Z-1).flow: unknown field 'sped_mps'; did you mean 'speed_mps'?",
        "scene.yaml:8:58: actors[0] (P-1).behaviour: Input should be 'walking', 'running', 'standing', 'sitting', "
        "'resting', 'collapsed', 'driving' or 'parked' (got 'lying')",
        "scene.yaml:9:47: actors[1] (P-2): unknown field 'behavior'; did you mean 'behaviour'?",
        "scene.yaml:10:25: actors[2] (P-3).position: missing required field 'east'",
    ]


def test_inconsistent_scenes_point_at_the_field_at_fault(tmp_path):
    problems = problems_of(
        tmp_path,
        """\
        id: bad-two
        zones:
          - id: Z-1
            polygon: [{north: 0, east: 0}, {north: 10, east: 0}, {north: 10, east: 10}]
            density: 0.5
            mix: {walking: 1, collapsed: 0.1}
        actors:
          - {id: P-1, position: {north: 0, east: 20}, behaviour: collapsed}
          - {id: P-2, position: {north: 0, east: 25}, behaviour: sitting}
          - {id: V-1, class: vehicle, position: {north: 0, east: 50}, behaviour: parked}
          - {id: P-2, position: {north: 5, east: 25}, zone: Z-9}
        ground_truth:
          expected_severity: critical
          casualties: [P-1, P-7]
          isolated: [P-1]
          distractors: [P-1]
          persons: 12
        """,
    )
    assert problems == [
        "scene.yaml:6:23: zones[0] (Z-1).mix.collapsed: 'collapsed' cannot be in a crowd mix (casualties are explicit "
        "actors)",
        "scene.yaml:11:10: actors[3] (P-2).id: id 'P-2' is already used by actors[1]",
        "scene.yaml:11:53: actors[3] (P-2).zone: no zone 'Z-9'; zones: Z-1",
        "scene.yaml:14:21: ground_truth.casualties[1]: no actor 'P-7'",
        "scene.yaml:15:14: ground_truth.isolated[0]: P-1 is 5.0 m from others (isolation_m 15)",
        "scene.yaml:16:17: ground_truth.distractors[0]: P-1 is a casualty, not a distractor",
        "scene.yaml:17:12: ground_truth.persons: the scene holds 28 persons, not 12",
    ]


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"id: x\nseed: 1\nactors: [\n", "scene.yaml:4:1: YAML syntax error: did not find expected node content"),
        (b"id: x\nseed: 1\nseed: 2\n", "scene.yaml:3:1: duplicate key 'seed' (first at line 2)"),
        (b"", "scene.yaml:1:1: the file is empty; a scene needs at least an id"),
        (b"- 1\n- 2\n", "scene.yaml:1:1: a scene is a mapping with an id, not a list"),
        (b"id: caf\xe9\n", "scene.yaml:1:8: not UTF-8 text: byte 0xe9 cannot be read; save the file as UTF-8"),
        (b"seed: 3\n", "scene.yaml:1:1: missing required field 'id'"),
        (
            b"id: x\nzones:\n  - id: Z\n    circle: {center: {north: 0, east: 0}, radius_m: 5}\n"
            b"    polygon: [{north: 0, east: 0}, {north: 1, east: 0}, {north: 1, east: 1}]\n",
            "scene.yaml:3:5: zones[0] (Z): a zone needs exactly one of polygon or circle",
        ),
        (b"id: x\nlandmarks:\n  - {id: L, kind: well, position: {north: 0, east: 0}}\n", "landmarks[0] (L).kind"),
        (b"id: x\na: &r [*r]\n", "scene.yaml:2:4: a YAML alias refers to itself: the document would be infinite"),
        (b"id: x\na: &m {b: *m}\n", "scene.yaml:2:4: a YAML alias refers to itself: the document would be infinite"),
    ],
)
def test_broken_files_are_reported_not_raised(tmp_path, content, expected):
    path = tmp_path / "scene.yaml"
    path.write_bytes(content)
    with pytest.raises(SceneFileError) as info:
        load_scene(path, file="scene.yaml")
    assert expected in str(info.value)
    assert str(info.value).startswith("scene.yaml:")


def test_a_missing_file_and_text_sources():
    with pytest.raises(SceneFileError, match=r"^nowhere\.yaml:1:1: cannot read the file"):
        load_scene("nowhere.yaml")
    scene = load_scene("id: inline\nseed: 4\n")
    assert scene.id == "inline" and scene.seed == 4
    with pytest.raises(SceneFileError, match=r"^<scene>:1:5: id: String should match pattern"):
        load_scene("id: 9bad\n")
    assert str(SceneProblem("f.yaml", 3, 7, "message")) == "f.yaml:3:7: message"


def test_saved_scenes_load_back(tmp_path):
    scene = generate_scene(21, casualties=1, distractors=3)
    save_scene(scene, tmp_path / "gen.yaml")
    assert load_scene(tmp_path / "gen.yaml") == scene
    assert (tmp_path / "gen.yaml").read_text().startswith("# yaml-language-server: $schema=scene.schema.json")


def test_the_shipped_schema_is_current_and_accepts_the_shipped_scenes():
    shipped = json.loads(SCHEMA_FILE.read_text())
    assert shipped == scene_json_schema(), f"scenes/scene.schema.json is out of date; regenerate it: {REGENERATE}"
    for path in sorted(SCENES.glob("*.yaml")):
        jsonschema.validate(yaml.safe_load(path.read_text()), shipped)
        assert path.read_text().startswith("# yaml-language-server: $schema=scene.schema.json")
        load_scene(path)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"id": "x", "actors": [{"id": "P-1", "position": {"north": 0}}]}, shipped)


def test_the_schema_command_prints_the_shipped_schema(capsys):
    from agentic_core.cli import main

    assert main(["schema", "scene"]) == 0
    assert capsys.readouterr().out == (REPO / "scenes" / "scene.schema.json").read_text(encoding="utf-8")
