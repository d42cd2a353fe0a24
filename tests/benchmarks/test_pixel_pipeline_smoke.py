"""Smoke test: ``benchmarks/pixel_pipeline.py`` runs to the end on a small size and prints its table with a verdict
(no timing checks)."""

import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("onnxruntime")
SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "pixel_pipeline.py"


def test_small_run_prints_the_table_and_the_verdict() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--sizes", "20", "200", "--frames", "2", "--warmup", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=SCRIPT.parent.parent,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0].startswith("pixel pipeline benchmark")
    assert lines[2].split() == ["detector", "persons", "objects", "cpu", "wall", "sensing", "pipeline", "fps/core"]
    rows = [line.split() for line in lines[3:7]]
    assert [(row[0], row[1]) for row in rows] == [("ours", "20"), ("ours", "200"), ("sim", "20"), ("sim", "200")]
    assert all(float(value) > 0.0 for row in rows for value in row[3:])
    assert lines[7].startswith("target: >= 30 frames per CPU-second with ours at 200 persons -> ")
    assert lines[7].split(" -> ")[1].split()[0] in ("PASS", "MISS")


def test_bad_options_are_refused_by_name() -> None:
    proc = subprocess.run([sys.executable, str(SCRIPT), "--frames", "0"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and "--frames must be positive" in proc.stderr
