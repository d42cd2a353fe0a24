"""The README's Python examples run and print what the README says they print."""

import contextlib
import io
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def _run_block(marker: str) -> list[str]:
    """Run the README's Python block that contains ``marker``; its printed lines."""
    (code,) = [block for block in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if marker in block]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    return out.getvalue().splitlines()


def test_quickstart_runs_as_documented() -> None:
    lines = _run_block("more_legs")
    assert lines[0].startswith("[Interrupt(value={'question': 'land near the crowd?'}, id=")
    assert lines[1] == "['leg 0', 'leg 1', 'leg 2', 'landed']"
    assert "graph TD;" in lines


def test_tools_example_runs_as_documented() -> None:
    lines = _run_block("water.depth")
    stages = "'lookup:passed', 'validate_args:passed', 'authorize:passed', 'rate_limit:passed', 'cache:miss'"
    assert lines[0].startswith(f"ok {{'depth_m': 4.2}} [{stages}, 'circuit_breaker:passed', 'invoke:passed'")
    assert lines[0].endswith("'injection_guard:passed', 'audit:passed']")
    assert lines[1] == "invalid arguments: $.lat: 'north' is not of type 'number'"


def test_langgraph_agent_example_runs_as_documented() -> None:
    assert _run_block("tools_condition") == ["Battery at 87%."]


def test_control_port_example_runs_as_documented(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = README.parent
    for name in ("missions", "scenes"):
        (tmp_path / name).symlink_to(repo / name)
    monkeypatch.chdir(tmp_path)
    assert _run_block("home_once_up")[-1] == "returned"  # after what JSBSim prints as it loads
