"""The mission language's one new notion: a step or trigger names a role or ``any`` UAV. Wrong names are refused
with the file and line; one-drone missions may not name a UAV; each UAV's share keeps only what is its own."""

from __future__ import annotations

import textwrap
from pathlib import Path

import pytest
import yaml

from agentic_core.cli import main
from agentic_core.mission.source import MissionError
from agentic_core.mission.validate import load_mission
from agentic_core.swarm.projection import project

REPO = Path(__file__).resolve().parents[3]
SWARM = """\
plan_id: s
goal: g
params: {layer_m: {type: number, default: 30}}
swarm:
  area: [{lat: 21.41, lon: 39.89}, {lat: 21.42, lon: 39.89}, {lat: 21.42, lon: 39.90}]
  roles: {medic: {count: 1, payload: [medkit]}}
steps:
  - {id: up, action: takeoff, args: {altitude_m: "${params.layer_m}"}}
  - id: loop
    action: repeat
    depends_on: [up]
    until: "loop.iterations >= 1"
    steps:
      - {id: drop, action: deploy_payload, uav: %s}
      - {id: look, action: hover, args: {duration_s: 1}}
  - {id: home, action: rtl, depends_on: [loop]}
triggers:
  - {id: seen, uav: any, when: "vehicle.armed", steps: [{id: note, action: hover, args: {duration_s: 1}}]}
"""


def test_a_step_naming_an_unknown_role_is_refused_with_its_file_and_line() -> None:
    with pytest.raises(MissionError) as error:
        load_mission(SWARM % "pilot", file="swarm.yaml")
    assert "swarm.yaml:" in str(error.value) and "'pilot' is neither 'any' nor a role" in str(error.value)


def test_a_one_drone_mission_may_not_name_a_uav() -> None:
    text = "plan_id: p\ngoal: g\nsteps:\n  - {id: up, action: takeoff, uav: any}\n"
    with pytest.raises(MissionError, match="needs a swarm: block"):
        load_mission(text, file="one.yaml")


def test_any_cannot_be_a_roles_name() -> None:
    with pytest.raises(MissionError, match="cannot be a role"):
        load_mission((SWARM % "medic").replace("roles: {medic:", "roles: {any:"), file="swarm.yaml")


def test_each_uav_keeps_only_its_own_steps_and_the_rest_still_validates(tmp_path: Path) -> None:
    raw = yaml.safe_load(SWARM % "medic")
    scout = project(raw, role=None, params={"layer_m": 40.0})
    medic = project(raw, role="medic", params={"layer_m": 50.0})
    assert [s["id"] for s in scout["steps"][1]["steps"]] == ["look"]
    assert [s["id"] for s in medic["steps"][1]["steps"]] == ["drop", "look"]
    assert [t["id"] for t in scout["triggers"]] == ["seen"]  # any: every UAV watches
    assert scout["params"]["layer_m"]["default"] == 40.0 and medic["params"]["layer_m"]["default"] == 50.0
    assert raw["params"]["layer_m"]["default"] == 30  # the swarm's mission itself is left alone
    for name, share in (("scout", scout), ("medic", medic)):
        path = tmp_path / f"{name}.yaml"
        path.write_text(yaml.safe_dump(share), encoding="utf-8")
        load_mission(path)


def test_a_dropped_step_leaves_the_depends_on_lists_it_was_in() -> None:
    raw = yaml.safe_load(SWARM % "medic")
    raw["steps"].insert(1, {"id": "kit", "action": "deploy_payload", "uav": "medic"})
    raw["steps"][2]["depends_on"] = ["up", "kit"]
    scout = project(raw, role=None, params={})
    assert [s["id"] for s in scout["steps"]] == ["up", "loop", "home"]
    assert scout["steps"][1]["depends_on"] == ["up"]


def test_validate_knows_the_swarms_tools_and_checks_their_arguments(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["validate", str(REPO / "missions" / "hajj_swarm.yaml")]) == 0
    bad = tmp_path / "bad.yaml"
    text = (REPO / "missions" / "hajj_swarm.yaml").read_text(encoding="utf-8")
    bad.write_text(text.replace('args: {casualty: "${claim.casualty}"}', "args: {patient: 3}"), encoding="utf-8")
    capsys.readouterr()
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"{bad}:" in err and "patient" in err and "Traceback" not in err


def test_swarm_run_refuses_a_mission_without_a_swarm_block(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["swarm", "run", str(REPO / "missions" / "hajj_emergency.yaml"), "--vehicles", "2"]) == 2
    err = capsys.readouterr().err
    assert "hajj_emergency.yaml: not a swarm mission" in err and "Traceback" not in err


def test_swarm_run_refuses_too_few_vehicles(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["swarm", "run", str(REPO / "missions" / "hajj_swarm.yaml"), "--vehicles", "0"]) == 2
    assert "--vehicles 0" in capsys.readouterr().err


def test_a_textwrap_sanity_the_fixture_is_a_mission() -> None:
    plan = load_mission(textwrap.dedent(SWARM % "medic"), file="ok.yaml")
    assert plan.swarm is not None and plan.swarm.role_of(0) == "medic" and plan.swarm.role_of(1) is None
