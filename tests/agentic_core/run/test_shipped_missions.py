"""Every mission shipped in ``missions/`` flies end to end on the embedded defaults: its scene found by its name
(``scenes/<mission>.yaml``), the rules reasoner, the in-process simulator at full speed. One patrol round and a
slower camera keep each run to seconds of the test; nothing else is changed."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from agentic_core.mission import load_mission
from agentic_core.run.runner import RunSettings, default_scene, run_mission
from flight.sim.scene_file import load_scene

REPO = Path(__file__).resolve().parents[3]
SHIPPED = sorted(p for p in (REPO / "missions").glob("*.yaml") if load_mission(p).swarm is None)
"""The one-drone missions; a swarm mission (hajj_swarm) flies in tests/agentic_core/run/test_swarm_run.py."""
CAMERA_HZ = 5.0
"""Frames per second of the camera: enough to find, watch and confirm the casualty; a sixth of the default."""

pytestmark = pytest.mark.timeout(900)  # the full scenes, on a shared machine


def test_the_missions_folder_is_what_these_tests_fly() -> None:
    assert [p.stem for p in SHIPPED] == ["hajj_emergency", "hajj_patrol", "inspect_perimeter"]


@pytest.mark.slow
@pytest.mark.parametrize("mission", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_a_shipped_mission_flies_end_to_end_on_the_defaults(tmp_path: Path, mission: Path, smtp: Any) -> None:
    scene_file = default_scene(mission)
    assert scene_file == REPO / "scenes" / f"{mission.stem}.yaml", "every shipped mission has its scene"
    params = {"rounds": "1"} if "rounds" in load_mission(mission).params else {}
    settings = RunSettings(mission=mission, runs_dir=tmp_path, params=params, camera_hz=CAMERA_HZ)
    result = run_mission(settings, progress=None)
    assert result.summary.outcome == "completed", result.summary  # alerts by SMTP: not degraded
    assert result.summary.scene == load_scene(scene_file).id
    records: list[dict[str, Any]] = [
        json.loads(line) for line in (result.run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()
    ]
    tools = [r for r in records if r["kind"] == "tool"]
    looks = [r for r in tools if r["name"] == "perception.analyze_scene"]
    assert looks and all(r["status"] == "ok" for r in looks), looks
    assert [r["name"] for r in tools if r["status"] == "ok"][-1] == "flight.rtl"
    (end,) = [r for r in records if r["kind"] == "run" and r.get("event") == "end"]
    assert end["ended"].startswith("on the ground, disarmed"), end
    if load_scene(scene_file).ground_truth.casualties:  # the emergency: the casualty was helped
        assert [r for r in tools if r["name"] == "alerts.notify" and r["status"] == "ok"]
        assert [r for r in tools if r["name"] == "flight.deploy_payload" and r["status"] == "ok"]
