"""Smoke test: ``benchmarks/graph_overhead.py --quick`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "graph_overhead.py"


@pytest.mark.slow
def test_quick_run_prints_the_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=SCRIPT.parent.parent,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = proc.stdout
    assert "agentic_core.graph overhead benchmark" in out
    for section in ("Case 1: per-superstep overhead", "Case 2: checkpoint growth", "Case 3: import time", "Targets"):
        assert section in out, out
