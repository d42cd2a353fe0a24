"""A tool definition file's problems are LocatedProblems whose line and column point at the field written wrong."""

from __future__ import annotations

from pathlib import Path

import pytest

from agentic_core.contracts.problems import LocatedProblem, ProblemsError
from tools import ToolDefinitionError, ToolRegistry
from tools.http_endpoint import load_http_tools
from tools.loading import load_tools

TEXT = """\
# endpoints, written with traps: a flow mapping, a key written twice, fields out of order
tools:
  - url: https://api.example.org/v2/roads
    name: traffic.roads
    timeout_s: -3
  - {name: air.now, url: "https://air.example/now", metod: GET}
  - name: dispatch.ticket
    url: https://dispatch.example/t
    method: POST
    method: FETCH
"""


def where(text: str, needle: str, occurrence: int = 1) -> tuple[int, int]:
    """1-based line and column of the ``occurrence``-th ``needle`` in ``text``, found by reading the text."""
    seen = 0
    for number, line in enumerate(text.splitlines(), start=1):
        start = line.find(needle)
        while start >= 0:
            seen += 1
            if seen == occurrence:
                return number, start + 1
            start = line.find(needle, start + 1)
    raise AssertionError(f"{needle!r} is not in the text {occurrence} times")


def located(path: Path) -> list[LocatedProblem]:
    with pytest.raises(ToolDefinitionError) as caught:
        load_http_tools(path)
    assert isinstance(caught.value, ProblemsError)
    assert caught.value.exit_status == 2
    return caught.value.problems


def test_each_problem_points_at_its_field(tmp_path: Path) -> None:
    path = tmp_path / "endpoints.yaml"
    path.write_text(TEXT)
    problems = located(path)
    assert {p.file for p in problems} == {str(path)}
    by_field = {p.message.split(":", 1)[0]: p for p in problems}
    expected = {
        "tools[0].timeout_s": where(TEXT, "timeout_s"),
        "tools[1].metod": where(TEXT, "metod"),
        "tools[2].method": where(TEXT, "method:", 2),  # the second one, the one a loader keeps
    }
    assert set(expected) <= set(by_field), [str(p) for p in problems]
    for field, (line, col) in expected.items():
        assert (by_field[field].line, by_field[field].col) == (line, col), str(by_field[field])
        assert str(by_field[field]).startswith(f"{path}:{line}:{col}: {field}: ")
    assert "written twice (first at line 9)" in " ".join(p.message for p in problems)
    assert problems == sorted(problems)


def test_a_syntax_error_points_at_where_the_parser_stopped(tmp_path: Path) -> None:
    text = "tools:\n  - name: a.b\n    url: [unclosed\n  - name: c.d\n"
    path = tmp_path / "broken.yaml"
    path.write_text(text)
    (problem,) = located(path)
    assert problem.file == str(path) and problem.line is not None and problem.col is not None
    assert problem.line >= where(text, "[unclosed")[0]
    assert problem.message.startswith("not valid YAML or JSON")


def test_a_python_tool_files_syntax_error_is_located(tmp_path: Path) -> None:
    text = "from tools import tool\n\n\ndef broken(:\n    pass\n"
    path = tmp_path / "mytools.py"
    path.write_text(text)
    with pytest.raises(ToolDefinitionError) as caught:
        load_tools(ToolRegistry(), str(path))
    (problem,) = caught.value.problems
    assert (problem.file, problem.line) == (str(path), where(text, "def broken")[0])
    assert problem.col is not None and problem.col >= 1


def test_a_definition_made_in_code_keeps_its_one_message() -> None:
    error = ToolDefinitionError("tool 'x': parameter 'y' needs a type hint")
    assert str(error) == "tool 'x': parameter 'y' needs a type hint"
    assert [(p.file, p.line, p.col) for p in error.problems] == [("", None, None)]
