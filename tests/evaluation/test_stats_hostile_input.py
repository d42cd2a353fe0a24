"""Hostile results files: integers too large for a double, long free-text columns, column names with commas.
Each is either analysed correctly or refused with exit 2 naming the file, the record or line, and the field."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from evaluation.stats import main
from evaluation.stats.dataset import load_dataset
from evaluation.stats.errors import InputError


def _records(digits: int) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = [{"group": g, "v": i + 1} for i, g in enumerate("AABB")]
    rows.insert(2, {"group": "A", "v": "{huge}"})
    return rows


def _write(path: Path, digits: int) -> Path:
    huge = "9" * digits
    if path.suffix == ".jsonl":
        lines = [json.dumps(r) for r in _records(digits)]
        text = "\n".join(lines).replace('"{huge}"', huge) + "\n"
    else:
        text = json.dumps(_records(digits)).replace('"{huge}"', huge)
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("digits", [310, 401, 4301, 20_000])
@pytest.mark.parametrize("suffix", [".json", ".jsonl"])
def test_an_integer_too_large_for_a_double_is_bad_input_naming_record_and_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], digits: int, suffix: str
) -> None:
    path = _write(tmp_path / f"r{suffix}", digits)
    assert main([str(path)]) == 2
    err = capsys.readouterr().err
    where = f"{path}:3: " if suffix == ".jsonl" else f"{path}: record 3, "
    assert f"{where}field 'v': " in err and "too large" in err
    assert "Traceback" not in err and "9" * 400 not in err  # the number is described, not echoed


def test_a_python_record_with_a_huge_integer_is_bad_input() -> None:
    records = [{"group": "A", "v": 1}, {"group": "A", "v": 10**400}, {"group": "B", "v": 3}, {"group": "B", "v": 4}]
    with pytest.raises(InputError, match=r"record 2, field 'v': .*too large"):
        load_dataset(records)


def test_large_integers_a_double_holds_are_numbers(tmp_path: Path) -> None:
    rows = [{"group": g, "v": v} for g, v in zip("AABB", [10**300, 2 * 10**300, 3 * 10**300, 5 * 10**300], strict=True)]
    path = tmp_path / "r.json"
    path.write_text(json.dumps(rows), encoding="utf-8")
    (column,) = load_dataset(path).columns
    assert column.kind == "continuous" and float(column.values.max()) == 5e300


@pytest.mark.parametrize("distinct", [21, 101, 250])
def test_a_text_column_with_many_distinct_values_is_skipped_as_free_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], distinct: int
) -> None:
    stamps = [f"2026-11-28T06:{i // 60:02d}:{i % 60:02d}" for i in range(distinct)]
    rows = ["timestamp,group,latency_ms"] + [
        f"{t},{'AB'[i % 2]},{10 + (i * 7919) % 13 / 3:.3f}" for i, t in enumerate(stamps)
    ]
    path = tmp_path / "t.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    assert main([str(path), "--format", "json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["group_column"] == "group"
    assert [c["column"] for c in report["continuous"]] == ["latency_ms"]
    assert report["skipped"] == [{"column": "timestamp", "reason": f"free text ({distinct} distinct values)"}]


def test_a_free_text_column_asked_for_as_categories_is_refused_by_name(tmp_path: Path) -> None:
    rows = ["group,note,x"] + [f"{'AB'[i % 2]},note {i},{i}" for i in range(150)]
    path = tmp_path / "t.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"'note': 150 distinct text values"):
        load_dataset(path, categorical=["note"])


def _comma_csv(tmp_path: Path) -> Path:
    path = tmp_path / "c.csv"
    rows = ['group,"time, s",time,s,score'] + [f"{'AB'[i % 2]},{i * 1.5},{100 + i},{-i},{i % 5}" for i in range(12)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize(
    ("value", "columns"),
    [
        ("time, s", ["time, s"]),
        ("time,s", ["time", "s"]),
        ("time, s,score", ["time, s", "score"]),
        ("score,time, s", ["score", "time, s"]),
        ("s, time", ["s", "time"]),
    ],
)
def test_a_column_named_with_a_comma_is_chosen_by_its_whole_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str, columns: list[str]
) -> None:
    assert main([str(_comma_csv(tmp_path)), "--value", value, "--format", "json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert [c["column"] for c in report["continuous"]] == columns


def test_an_unknown_column_lists_the_columns_quoted(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main([str(_comma_csv(tmp_path)), "--value", "time, m"]) == 2
    err = capsys.readouterr().err
    assert "no column 'm'; the columns are: 'group', 'time, s', 'time', 's', 'score'" in err
