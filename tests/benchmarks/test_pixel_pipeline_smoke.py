"""Smoke test: ``benchmarks/pixel_pipeline.py`` runs to the end on a small size and prints its table with a verdict
(no timing checks)."""

import pytest

from .script import run_script, table

pytest.importorskip("onnxruntime")


def test_small_run_prints_the_table_and_the_verdict() -> None:
    out = table("pixel_pipeline.py", "--sizes", "20", "200", "--frames", "2", "--warmup", "1")
    lines = out.splitlines()
    assert lines[0].startswith("pixel pipeline benchmark")
    head = ["detector", "height", "persons", "objects", "cpu", "wall", "sensing", "pipeline", "fps/core"]
    assert lines[2].split() == head
    rows = [line.split() for line in lines[3:9]]
    assert [tuple(row[:3]) for row in rows] == [
        ("ours", "30m", "20"), ("ours", "30m", "200"), ("ours", "15m", "20"), ("ours", "15m", "200"),
        ("sim", "30m", "20"), ("sim", "30m", "200"),
    ]  # fmt: skip
    assert all(float(value) > 0.0 for row in rows for value in row[4:])
    assert lines[9].startswith("target: >= 30 frames per CPU-second with ours at 200 persons -> ")
    assert lines[9].split(" -> ")[1].split()[0] in ("PASS", "MISS")


def test_bad_options_are_refused_by_name() -> None:
    for bad in (["--frames", "0"], ["--close-m", "0"]):
        proc = run_script("pixel_pipeline.py", *bad, timeout_s=60)
        assert proc.returncode == 2 and "--frames and --close-m must be positive" in proc.stderr, bad
