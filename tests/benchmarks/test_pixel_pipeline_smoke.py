"""Smoke test: ``benchmarks/pixel_pipeline.py`` runs to the end on a small size and prints its table with a verdict
(no timing checks)."""

import pytest

from .script import run_script, table

pytest.importorskip("onnxruntime")


def test_small_run_prints_the_table_and_the_verdict() -> None:
    out = table("pixel_pipeline.py", "--sizes", "20", "200", "--frames", "2", "--warmup", "1")
    lines = out.splitlines()
    assert lines[0].startswith("pixel pipeline benchmark")
    assert lines[2].split() == ["detector", "persons", "objects", "cpu", "wall", "sensing", "pipeline", "fps/core"]
    rows = [line.split() for line in lines[3:7]]
    assert [(row[0], row[1]) for row in rows] == [("ours", "20"), ("ours", "200"), ("sim", "20"), ("sim", "200")]
    assert all(float(value) > 0.0 for row in rows for value in row[3:])
    assert lines[7].startswith("target: >= 30 frames per CPU-second with ours at 200 persons -> ")
    assert lines[7].split(" -> ")[1].split()[0] in ("PASS", "MISS")


def test_bad_options_are_refused_by_name() -> None:
    proc = run_script("pixel_pipeline.py", "--frames", "0", timeout_s=60)
    assert proc.returncode == 2 and "--frames must be positive" in proc.stderr
