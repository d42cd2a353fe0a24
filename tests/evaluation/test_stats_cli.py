"""``eval stats`` main(): exit 0 with a report, exit 2 with a one-line message for bad input."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evaluation.stats import main


def _csv(tmp_path: Path) -> Path:
    path = tmp_path / "r.csv"
    rows = ["group,x,ok"] + [f"{'ab'[i % 2]},{i * 1.5 + (i % 2)},{'true' if i % 3 else 'false'}" for i in range(20)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_markdown_to_stdout_and_files(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main([str(_csv(tmp_path)), "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert "## Table 2 layout" in captured.out
    assert {p.name for p in out.iterdir()} == {"stats.md", "stats.tex", "stats.json", "stats_x.png", "stats_rates.png"}
    assert json.loads((out / "stats.json").read_text())["group_column"] == "group"


def test_json_and_value_selection(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(_csv(tmp_path)), "--value", "x", "--format", "json", "--group", "group"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [c["column"] for c in data["continuous"]] == ["x"] and data["categorical"] == []


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["missing.csv"], "missing.csv: no such file"),
        (["{csv}", "--value", "y"], "no column 'y'"),
        (["{csv}", "--group", "x"], "column 'x' has a different value on every row"),
        (["{csv}", "--alpha", "2"], "--alpha must be between 0 and 1"),
    ],
)
def test_bad_input_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str], args: list[str], message: str) -> None:
    csv = str(_csv(tmp_path))
    code = main([a.replace("{csv}", csv) for a in args])
    captured = capsys.readouterr()
    assert code == 2 and message in captured.err and "Traceback" not in captured.err
    assert captured.err.startswith("agentic-uav eval stats: error: ")


def test_non_numeric_cell(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text("group,x\na,1\na,2\nb,3\nb,three\nb,4\n", encoding="utf-8")
    assert main([str(path)]) == 2
    assert f"{path}:5:2: column 'x': non-numeric value 'three'" in capsys.readouterr().err


def test_usage_errors_and_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main([]) == 2
    assert main(["--help"]) == 0
    assert "RESULTS" in capsys.readouterr().out
