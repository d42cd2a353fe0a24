"""``agentic-uav run --tools SOURCE``: the user's own tools fly in a mission, loaded by the loader ``validate
--tools`` and ``mcp serve`` use; a source that cannot be loaded stops the run before anything flies."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.contracts.geodesy import local_offset

REPO = Path(__file__).resolve().parents[3]
MISSION = REPO / "tools" / "examples" / "fence_check.yaml"
TOOLS = REPO / "tools" / "examples" / "fence_tools.py"


def _trace(run_dir: Path) -> list[dict[str, object]]:
    return [json.loads(line) for line in (run_dir / "trace.jsonl").read_text(encoding="utf-8").splitlines()]


def test_a_custom_tool_flies_in_a_mission(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    assert main(["run", str(MISSION), "--tools", str(TOOLS), "--runs-dir", str(runs), "--quiet"]) == 0
    (run_dir,) = runs.iterdir()
    tools = [r for r in _trace(run_dir) if r["kind"] == "tool"]
    sensor = [r for r in tools if r["name"] == "fence.status"]
    assert [r["status"] for r in sensor] == ["ok"]
    names = [r["name"] for r in tools if r["status"] == "ok"]
    assert names.index("fence.status") < names.index("flight.takeoff") < names.index("flight.fly_to")
    # the aircraft went where the tool said the breach is (21.4141, 39.8952), not merely took off
    north, east = local_offset(21.4133, 39.8933, 21.4141, 39.8952)
    track = [json.loads(line) for line in (run_dir / "telemetry.jsonl").read_text(encoding="utf-8").splitlines()]
    closest = min(math.hypot(t["north_m"] - north, t["east_m"] - east) for t in track)
    assert closest < 5.0, closest
    assert json.loads((run_dir / "run.json").read_text(encoding="utf-8"))["settings"]["tools"] == [str(TOOLS)]


def test_without_its_tool_the_mission_is_refused_before_anything_flies(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    runs = tmp_path / "runs"
    assert main(["run", str(MISSION), "--runs-dir", str(runs), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "fence_check.yaml" in err and "fence.status" in err and "Traceback" not in err
    assert not runs.exists() or not any(runs.iterdir())


@pytest.mark.parametrize(
    ("source", "named"),
    [
        ("broken.py", "broken.py:2"),  # a syntax error, at its line
        ("no_such_module_xyz", "no_such_module_xyz"),
        ("missing.yaml", "missing.yaml: no such file"),
    ],
)
def test_a_tool_source_that_cannot_be_loaded_is_bad_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], source: str, named: str
) -> None:
    (tmp_path / "broken.py").write_text("from tools import tool\ndef oops(:\n", encoding="utf-8")
    path = str(tmp_path / source) if source.endswith((".py", ".yaml")) else source
    runs = tmp_path / "runs"
    assert main(["run", str(MISSION), "--tools", path, "--runs-dir", str(runs), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert named in err and "Traceback" not in err
    assert not runs.exists()


def test_resume_keeps_the_runs_own_tools(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--resume", "x", "--tools", str(TOOLS)]) == 2
    assert "tools" in capsys.readouterr().err
