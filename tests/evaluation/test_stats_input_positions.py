"""Statistics input reports one LocatedProblem whose line and column point at the cell written wrong."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agentic_core.contracts.problems import LocatedProblem, ProblemsError
from evaluation.stats.dataset import load_dataset
from evaluation.stats.errors import InputError


def only_problem(path: Path, **options: str) -> LocatedProblem:
    with pytest.raises(InputError) as caught:
        load_dataset(path, **options)
    assert isinstance(caught.value, ProblemsError) and caught.value.exit_status == 2
    (problem,) = caught.value.problems
    return problem


def test_a_bad_cell_after_a_quoted_multi_line_cell_is_found_on_its_own_line(tmp_path: Path) -> None:
    lines = [
        "note,group,latency_s",
        '"a note, with a comma",a,1.5',
        '"a note that goes on',
        'over two lines",a,2.5',
        ",b,3.0",
        "plain,b,slow",
        "last,b,4.0",
    ]
    path = tmp_path / "runs.csv"
    path.write_text("\n".join(lines) + "\n")
    problem = only_problem(path, group="group")
    line = next(n for n, text in enumerate(lines, start=1) if text.endswith(",slow"))
    field = lines[0].split(",").index("latency_s") + 1
    assert (problem.file, problem.line, problem.col) == (str(path), line, field)
    assert "'latency_s'" in problem.message and "'slow'" in problem.message
    assert str(problem).startswith(f"{path}:{line}:{field}: column 'latency_s': ")


def test_a_bad_cell_of_a_multi_line_record_is_placed_where_the_record_starts(tmp_path: Path) -> None:
    lines = ["group,note,x", "a,one,1", "a,two,2", 'b,"three', 'lines",oops', "b,four,4"]
    path = tmp_path / "runs.csv"
    path.write_text("\n".join(lines) + "\n")
    problem = only_problem(path, group="group")
    start = next(n for n, text in enumerate(lines, start=1) if text.startswith('b,"'))
    assert (problem.line, problem.col) == (start, lines[0].split(",").index("x") + 1)
    assert "column 'x'" in problem.message and "'oops'" in problem.message


def test_a_json_syntax_error_is_placed_on_its_line_and_column(tmp_path: Path) -> None:
    good = json.dumps({"group": "a", "x": 1})
    bad = '{"group": "b", "x": 2,, "y": 3}'
    path = tmp_path / "runs.jsonl"
    path.write_text(f"{good}\n\n{good}\n{bad}\n")
    problem = only_problem(path)
    assert (problem.line, problem.col) == (4, bad.index(",,") + 2)
    assert problem.message.startswith("invalid JSON")


def test_a_json_records_field_is_named_without_a_made_up_line(tmp_path: Path) -> None:
    rows = [{"g": "a", "x": 1}, {"g": "a", "x": 2}, {"g": "b", "x": "n/a?"}, {"g": "b", "x": 3}]
    path = tmp_path / "runs.json"
    path.write_text(json.dumps(rows))
    problem = only_problem(path, group="g")
    assert (problem.file, problem.line, problem.col) == (str(path), None, None)
    assert problem.message.startswith("record 3, field 'x': ")
