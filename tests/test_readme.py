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


@pytest.mark.slow
def test_control_port_example_runs_as_documented(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    repo = README.parent
    for name in ("missions", "scenes"):
        (tmp_path / name).symlink_to(repo / name)
    monkeypatch.chdir(tmp_path)
    assert _run_block("home_once_up")[-1] == "returned"  # after what JSBSim prints as it loads


def test_perception_example_runs_as_documented(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "scenes").symlink_to(README.parent / "scenes")
    monkeypatch.chdir(tmp_path)
    assert _run_block("SimulatedDetector") == ["True True"]
    assert (tmp_path / "frame.png").read_bytes()[:4] == b"\x89PNG"


def test_render_example_runs_as_documented(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(README.parent)
    (line,) = _run_block("render_spec")
    assert line.startswith("(480, 640, 3) lying [")


def test_the_custom_tool_example_is_the_shipped_file_and_registers() -> None:
    (code,) = [b for b in re.findall(r"```python\n(.*?)```", README.read_text(), re.S) if "fence.status" in b]
    shipped = (README.parent / "tools" / "examples" / "fence_tools.py").read_text()
    assert code in shipped  # the README shows the file the run command flies
    namespace: dict[str, object] = {"__name__": "readme"}
    exec(compile(code, "README.md", "exec"), namespace)
    status = namespace["fence_status"]
    assert callable(status) and status(segment="F-07")["breached"] is True


def test_the_swarm_example_prints_what_the_readme_says() -> None:
    lines = _run_block("manager.allocate(tasks)")
    (shown,) = [b for b in re.findall(r"```text\n(.*?)```", README.read_text(), re.S) if "sector-N" in b]
    assert lines == shown.splitlines()
    assert lines[0] == "{'sector-N': 'uav-2', 'kit-P12': 'uav-3'}"


def test_memory_example_runs_as_documented(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from agentic_core.memory.embed import available

    if not available():
        pytest.skip("the embed extra is not installed")
    monkeypatch.chdir(tmp_path)
    assert _run_block("someone collapsed in the sun") == ["['c1']"]
    assert (tmp_path / "memory.db").exists()


RUN_BY = {
    "more_legs": "test_quickstart_runs_as_documented",
    "water.depth": "test_tools_example_runs_as_documented",
    "tools_condition": "test_langgraph_agent_example_runs_as_documented",
    "home_once_up": "test_control_port_example_runs_as_documented",
    "SimulatedDetector": "test_perception_example_runs_as_documented",
    "render_spec": "test_render_example_runs_as_documented",
    "fence.status": "test_the_custom_tool_example_is_the_shipped_file_and_registers",
    "manager.allocate(tasks)": "test_the_swarm_example_prints_what_the_readme_says",
    "someone collapsed in the sun": "test_memory_example_runs_as_documented",
}
"""Each README Python block, by a marker it holds, and the test here that runs it."""


def test_every_python_block_of_the_readme_is_run_here() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)
    for block in blocks:
        markers = [m for m in RUN_BY if m in block]
        assert len(markers) == 1, f"a README Python block no test runs (or two claim):\n{block[:200]}"
        assert RUN_BY[markers[0]] in globals()
    assert len(blocks) == len(RUN_BY)
