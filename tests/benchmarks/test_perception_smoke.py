"""Smoke test: ``benchmarks/perception.py`` runs to the end on small sizes and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "perception.py"


def test_small_run_prints_the_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--sizes", "20", "200", "--frames", "5", "--warmup", "5", "--repeats", "1"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=SCRIPT.parent.parent,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0] == "perception update benchmark"
    header = lines[2].split()
    assert header[:6] == ["persons", "measure", "track", "relations", "contract", "total"]
    rows = [line.split() for line in lines[3:5]]
    assert [row[0] for row in rows] == ["20", "200"]
    assert all(float(value) >= 0.0 for row in rows for value in row[1:6])
    assert lines[5].startswith("growth: 20->200 persons:")
    assert lines[-1].startswith("target: median < 5 ms at 200 persons -> ")
    assert lines[-1].split(" -> ")[1].split()[0] in ("PASS", "MISS")


def test_bad_arguments_are_a_usage_error() -> None:
    proc = subprocess.run([sys.executable, str(SCRIPT), "--frames", "0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "must be at least 1" in proc.stderr
