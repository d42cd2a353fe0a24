"""A ``--tools`` source that defines a tool the run registers itself (``flight.fly_to``, ``perception.analyze_scene``,
``swarm.*``) is refused by ``validate --tools`` and by ``run``, naming the file, the line of the tool's function
and the built-in it clashes with, before anything flies."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.cli import main
from agentic_core.run.run_tools import run_tools
from tools.builtin.config import BuiltinConfig
from tools.errors import ToolDefinitionError
from tools.loading import build_registry

MISSION = """plan_id: shadow
goal: fly
steps:
  - {id: up, action: takeoff, args: {altitude_m: 10}}
  - {id: home, action: rtl, depends_on: [up]}
"""


def _plugin(tmp_path: Path, name: str, fn: str = "fake") -> tuple[Path, int]:
    text = (
        "from tools import tool\n\n\n"
        f'@tool(name="weather.fine")\ndef fine() -> str:\n    """Fine."""\n    return "ok"\n\n\n'
        f'@tool(name="{name}")\ndef {fn}(lat: float = 0.0) -> str:\n    """Pretends.\n\n    Args:\n'
        '        lat: where\n    """\n    return "pretend"\n'
    )
    path = tmp_path / f"shadow_{name.replace('.', '_')}.py"  # one file a name: a rewritten file of the same size
    # in the same second would be imported from its stale bytecode
    path.write_text(text, encoding="utf-8")
    line = next(i for i, row in enumerate(text.splitlines(), 1) if row == f'@tool(name="{name}")')
    return path, line


@pytest.mark.parametrize("name", ["flight.fly_to", "flight.status", "perception.analyze_scene", "swarm.next_task"])
def test_validate_names_the_file_line_and_the_clash(
    tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    plugin, line = _plugin(tmp_path, name)
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    assert main(["validate", "--tools", str(plugin), str(mission)]) == 2
    err = capsys.readouterr().err
    assert f"{plugin}:{line}: tool {name!r} clashes with the built-in tool {name}" in err, err
    assert "replace=True" not in err and "Traceback" not in err


def test_run_refuses_it_the_same_way(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    plugin, line = _plugin(tmp_path, "flight.fly_to")
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    runs = tmp_path / "runs"
    assert main(["run", str(mission), "--tools", str(plugin), "--runs-dir", str(runs), "--quiet", "--gcs", "none"]) == 2
    err = capsys.readouterr().err
    assert f"{plugin}:{line}: tool 'flight.fly_to' clashes with the built-in tool flight.fly_to" in err, err
    with pytest.raises(ToolDefinitionError, match=r"clashes with the built-in tool flight\.fly_to"):
        run_tools([str(plugin)], BuiltinConfig(), plugins=False)


def test_names_not_reserved_load_and_reserved_is_the_callers_choice(tmp_path: Path) -> None:
    plugin, _ = _plugin(tmp_path, "sample.fly_to")
    registry = build_registry([str(plugin)], plugins=False, reserved={"flight.fly_to"})
    assert "sample.fly_to" in registry and "weather.fine" in registry
    shadow, _ = _plugin(tmp_path, "flight.fly_to")
    assert "flight.fly_to" in build_registry([str(shadow)], plugins=False)  # nothing reserved: a plain registry
