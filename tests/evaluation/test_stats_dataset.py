"""Reading results and detecting columns; every user mistake is a clear InputError naming file, line, column."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from pydantic import BaseModel

from evaluation.stats import InputError, load_dataset, readers
from evaluation.stats.dataset import CategoricalColumn, ContinuousColumn, Dataset

DECISION_HEADER = "scene_id,system,processing_time_s,detection_confidence,person_detected,n_actions,contextual,error"


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def decision_csv(tmp_path: Path) -> Path:
    rows = [DECISION_HEADER]
    for i in range(6):
        rows.append(f"s{i},yolo,{2.9e-5 + i * 1e-6},0.7{i},{'True' if i % 2 else 'False'},0,False,")
        rows.append(
            f"s{i},gpt4,{4.9 + i / 10},0.8{i},True,{i % 3},{'True' if i else 'False'},{'timeout' if i == 5 else ''}"
        )
    return write(tmp_path, "results.csv", "\n".join(rows) + "\n")


def test_decision_records_schema(tmp_path: Path) -> None:
    ds = load_dataset(decision_csv(tmp_path))
    assert ds.schema == "decision-records" and ds.group_column == "system" and ds.groups == ("yolo", "gpt4")
    names = [c.name for c in ds.columns]
    assert names == ["processing_time_s", "detection_confidence", "person_detected", "action_recommended", "contextual"]
    arr = ds.column("action_recommended")
    assert isinstance(arr, CategoricalColumn) and arr.kind == "binary"
    assert arr.codes.tolist() == [0, 0, 0, 1, 0, 1, 0, 0, 0, 1, 0, 1]  # n_actions >= 1
    assert {s.column for s in ds.skipped} == {"scene_id", "n_actions", "error"}
    assert any("error" in n and "gpt4: 1" in n for n in ds.notes)


def test_generic_csv_detection_and_kinds(tmp_path: Path) -> None:
    path = write(
        tmp_path,
        "user.csv",
        "id,arm,time_ms,ok,severity,notes\n"
        + "\n".join(
            f"{i},{'AB'[i % 2]},{1.5 + i},{'yes' if i % 3 else 'no'},{['low', 'high'][i % 2]},note {i}"
            for i in range(12)
        )
        + "\n",
    )
    ds = load_dataset(path)
    assert ds.group_column == "arm" and ds.groups == ("A", "B")
    kinds = {c.name: c.kind for c in ds.columns}
    assert kinds == {"time_ms": "continuous", "ok": "binary", "severity": "categorical"}
    assert {s.column: s.reason for s in ds.skipped}["id"] == "identifier"
    assert "notes" in {s.column for s in ds.skipped}
    time = ds.column("time_ms")
    assert isinstance(time, ContinuousColumn) and time.unit == "ms"


def test_json_jsonl_and_records_give_the_same_dataset(tmp_path: Path) -> None:
    typed = [(g, float(i), bool(i % 2)) for i, g in enumerate("aabbcc")]
    rows = [{"group": g, "x": x, "flag": f} for g, x, f in typed]
    a = load_dataset(write(tmp_path, "r.json", json.dumps(rows)))
    b = load_dataset(write(tmp_path, "r.jsonl", "\n".join(json.dumps(r) for r in rows)))
    c = load_dataset(rows)

    class Rec(BaseModel):
        group: str
        x: float
        flag: bool

    @dataclass
    class DRec:
        group: str
        x: float
        flag: bool

    d = load_dataset([Rec.model_validate(r) for r in rows])
    e = load_dataset([DRec(g, x, f) for g, x, f in typed])
    for ds in (a, b, c, d, e):
        assert ds.groups == ("a", "b", "c")
        x = ds.column("x")
        assert isinstance(x, ContinuousColumn) and x.values.tolist() == [0, 1, 2, 3, 4, 5]
        assert ds.column("flag").kind == "binary"


def test_from_groups_arrays() -> None:
    ds = Dataset.from_groups({"a": [1.0, 2.0, np.nan], "b": [3.0, 4.0]}, name="latency_s")
    samples, missing = ds.samples(ds.columns[0])  # type: ignore[arg-type]
    assert [s.tolist() for s in samples] == [[1.0, 2.0], [3.0, 4.0]] and missing == [1, 0]
    with pytest.raises(InputError, match="at least 2 groups"):
        Dataset.from_groups({"a": [1.0]})


def test_missing_tokens_are_missing(tmp_path: Path) -> None:
    path = write(tmp_path, "m.csv", "group,x\na,1\na,NA\na,\nb,nan\nb,2\nb,-\n")
    ds = load_dataset(path)
    x = ds.column("x")
    assert isinstance(x, ContinuousColumn) and int(np.isnan(x.values).sum()) == 4


# --------------------------------------------------------------------------- errors


def test_missing_file() -> None:
    with pytest.raises(InputError, match=r"nope\.csv: no such file"):
        load_dataset("nope.csv")


def test_unknown_column_lists_the_columns(tmp_path: Path) -> None:
    path = write(tmp_path, "u.csv", "group,x\na,1\nb,2\n")
    with pytest.raises(InputError, match=r"u\.csv: no column 'y'; the columns are: 'group', 'x'"):
        load_dataset(path, values=["y"])
    with pytest.raises(InputError, match="no column 'grp'"):
        load_dataset(path, group="grp")


def test_non_numeric_value_names_line_and_column(tmp_path: Path) -> None:
    path = write(tmp_path, "n.csv", "group,x,y\na,1,2\na,2,3\nb,fast,4\nb,3,5\n")
    with pytest.raises(InputError) as info:
        load_dataset(path)
    err = info.value
    assert (err.line, err.column, err.column_index) == (4, "x", 2)
    assert str(err) == f"{path}:4:2: column 'x': non-numeric value 'fast' in a numeric column"
    assert [(p.file, p.line, p.col) for p in err.problems] == [(str(path), 4, 2)]


def test_fewer_than_two_groups(tmp_path: Path) -> None:
    path = write(tmp_path, "g.csv", "group,x\na,1\na,2\n")
    with pytest.raises(InputError, match=r"at least 2 groups.*has 1 \('a'\)"):
        load_dataset(path)


def test_empty_group_value(tmp_path: Path) -> None:
    path = write(tmp_path, "e.csv", "group,x\na,1\n,2\nb,3\n")
    with pytest.raises(InputError, match=r"e\.csv:3:1: column 'group': empty group value"):
        load_dataset(path)


def test_ragged_row_and_bad_json(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"r\.csv:3: expected 2 fields \(as in the header\), found 3"):
        load_dataset(write(tmp_path, "r.csv", "group,x\na,1\nb,2,3\n"))
    bad_line = '{"group": "b", x}'
    with pytest.raises(InputError, match=rf"r\.jsonl:2:{bad_line.index('x}') + 1}: invalid JSON"):
        load_dataset(write(tmp_path, "r.jsonl", '{"group": "a", "x": 1}\n' + bad_line + "\n"))
    with pytest.raises(InputError, match=r"r\.json: record 2, field 'x': non-numeric value 'oops'"):
        load_dataset(
            write(tmp_path, "r.json", json.dumps([{"g": "a", "x": 1}, {"g": "b", "x": "oops"}, {"g": "b", "x": 2}])),
            group="g",
        )


def test_infinite_and_ambiguous_groups(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"i\.csv:3:2: column 'x': non-finite value 'inf'"):
        load_dataset(write(tmp_path, "i.csv", "group,x\na,1\nb,inf\n"))
    with pytest.raises(InputError, match=r"several columns could hold the groups \(team, site\)"):
        load_dataset(write(tmp_path, "a.csv", "team,site,x\nr,n,1\ns,m,2\nr,m,3\n"))


def test_fast_reader_falls_back_to_exact_lines(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A quoted field spanning two lines shifts row positions; the error must still name the true line."""
    monkeypatch.setattr(readers, "FAST_CSV_BYTES", 0)
    text = 'group,x,note\na,1,"two\nlines"\na,2,n\nb,3,n\nb,oops,n\nb,4,n\nb,5,n\n'
    path = write(tmp_path, "f.csv", text)
    with pytest.raises(InputError) as info:
        load_dataset(path, values=["x"])
    assert info.value.line == 6


def test_fast_and_slow_readers_agree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    lines = [DECISION_HEADER] + [
        f"s{i},{'abc'[i % 3]},{0.1 * i + 1e-7},{i / 100},{i % 2 == 0},{i % 4},{i % 3 == 0},{'err' if i == 7 else ''}"
        for i in range(60)
    ]
    path = write(tmp_path, "big.csv", "\n".join(lines) + "\n")
    slow = load_dataset(path)
    monkeypatch.setattr(readers, "FAST_CSV_BYTES", 0)
    raw = readers.read_path(path)
    assert not raw.exact
    fast = load_dataset(path)
    assert fast.groups == slow.groups and fast.notes == slow.notes
    for a, b in zip(fast.columns, slow.columns, strict=True):
        assert a.name == b.name and a.kind == b.kind
        if isinstance(a, ContinuousColumn) and isinstance(b, ContinuousColumn):
            assert np.array_equal(a.values, b.values, equal_nan=True)
        else:
            assert isinstance(a, CategoricalColumn) and isinstance(b, CategoricalColumn)
            assert np.array_equal(a.codes, b.codes) and a.levels == b.levels
