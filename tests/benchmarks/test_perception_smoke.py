"""Smoke test: ``benchmarks/perception.py`` runs to the end on small sizes and prints its table (no timing checks)."""

import re

import pytest

from .script import run_script, table


def test_small_run_prints_the_table() -> None:
    args = ["--sizes", "20", "200", "--frames", "5", "--warmup", "5", "--repeats", "1", "--render-sizes", "0", "200"]
    out = table("perception.py", *args)
    lines = out.splitlines()
    assert lines[0] == "perception update benchmark"
    header = lines[2].split()
    assert header[:6] == ["persons", "measure", "track", "relations", "contract", "total"]
    rows = [line.split() for line in lines[3:5]]
    assert [row[0] for row in rows] == ["20", "200"]
    assert all(float(value) >= 0.0 for row in rows for value in row[1:6])
    assert lines[5].startswith("growth: 20->200 persons:")
    (target,) = [line for line in lines if line.startswith("target: median < 5 ms at 200 persons -> ")]
    assert target.split(" -> ")[1].split()[0] in ("PASS", "MISS")
    start = lines.index("render benchmark (flight.sim.render: 640x480, 84 deg, straight down, 30 m)")
    assert lines[start + 2].split() == ["persons", "shown", "mean", "p95", "cpu"]
    rendered = [line.split() for line in lines[start + 3 : start + 5]]
    assert [row[0] for row in rendered] == ["0", "200"] and rendered[0][1] == "0"
    assert int(rendered[1][1]) >= 190  # the crowd is in view (a walker may step over the image's edge)
    assert all(float(value) > 0.0 for row in rendered for value in row[2:])
    assert lines[-1].startswith("render target: mean <= 15 ms at 200 persons -> ")


def test_bad_arguments_are_a_usage_error() -> None:
    proc = run_script("perception.py", "--frames", "0", timeout_s=120)
    assert proc.returncode == 2
    assert "must be at least 1" in proc.stderr


def test_the_detect_row_times_the_arrays_and_the_records() -> None:
    """``--detect N``: the shipped detector on N rendered frames, its arrays and then the Detection records a run
    gets, each a positive time."""
    pytest.importorskip("onnxruntime")
    out = table("perception.py", "--sizes", "5", "--frames", "1", "--warmup", "0", "--repeats", "1", "--render-sizes",
                "--detect", "2")  # fmt: skip
    (row,) = [line for line in out.splitlines() if line.startswith("detect (ours, 640x480, 1 thread): 2 frames, ")]
    times = re.findall(r"(?:mean|p95|cpu) ([0-9.]+) ms", row)
    assert len(times) == 4 and all(float(value) > 0.0 for value in times)
    assert "; with the Detection records: mean " in row
