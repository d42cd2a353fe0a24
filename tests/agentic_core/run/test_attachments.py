"""Alert attachments named by what they are become files of the run with the right content; what cannot be
produced is passed on by name (the alert lists it as unavailable)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agentic_core.run.attachments import materialize
from agentic_core.run.perception_loop import PerceptionLoop
from flight.camera import CameraPose
from flight.sim.scene_file import load_scene

SCENE = Path(__file__).resolve().parents[3] / "scenes" / "hajj_emergency.yaml"
ARGS = {"subject": "Collapse", "body": "help", "attach": ["world_model", "position", "assessment", "snapshot"]}


def hovering_loop(frames: int = 5) -> PerceptionLoop:
    loop = PerceptionLoop(load_scene(SCENE), seed=1)
    casualty = loop.scene.actor(loop.scene.ground_truth.casualties[0]).position
    pose = CameraPose(north_m=casualty.north, east_m=casualty.east, down_m=-30.0)
    for k in range(frames):
        loop.observe(pose, k * loop.camera.spec.frame_period_s)
    return loop


def test_every_name_becomes_a_file_with_what_the_agent_saw(tmp_path: Path) -> None:
    loop = hovering_loop()
    decision: dict[str, Any] = {"reasoner": "rules", "assessment": {"severity": "critical", "note": "Über"}}
    out = materialize(
        ARGS, out_dir=tmp_path / "alerts", stamp="000001.0s", loop=loop,
        position=lambda: {"lat": 21.4225, "lon": 39.8733}, last_decision=lambda: decision,
    )  # fmt: skip
    assert {k: v for k, v in out.items() if k != "attach"} == {"subject": "Collapse", "body": "help"}
    paths = [Path(p) for p in out["attach"]]
    assert [p.name for p in paths] == [
        "000001.0s-world_model.json", "000001.0s-position.json", "000001.0s-assessment.json",
        "000001.0s-snapshot.png",
    ]  # fmt: skip
    world_text = paths[0].read_text(encoding="utf-8")
    assert json.loads(world_text) == loop.world.to_dict() and world_text.startswith('{\n  "timestamp"')  # indented
    assert world_text == loop.world.to_json(indent=2) + "\n"  # the contract's own JSON
    assert json.loads(paths[1].read_text()) == {"lat": 21.4225, "lon": 39.8733}
    assert json.loads(paths[2].read_text(encoding="utf-8")) == decision
    assert paths[3].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_what_cannot_be_produced_is_passed_on_by_name(tmp_path: Path) -> None:
    out = materialize(
        {**ARGS, "attach": ["snapshot", "world_model", "position", "assessment", "thermal", str(tmp_path)]},
        out_dir=tmp_path / "alerts", stamp="s", loop=None, position=lambda: None, last_decision=lambda: None,
    )  # fmt: skip
    assert out["attach"] == ["snapshot", "world_model", "position", "assessment", "thermal", str(tmp_path)]
    assert materialize({"subject": "x"}, out_dir=tmp_path / "none", stamp="s", loop=None,
                       position=lambda: None, last_decision=lambda: None) == {"subject": "x"}  # fmt: skip
    assert not (tmp_path / "none").exists()
