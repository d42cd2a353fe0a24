"""Smoke test: ``benchmarks/tool_overhead.py --quick`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "tool_overhead.py"


def test_quick_run_prints_the_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"], capture_output=True, text=True, timeout=300, cwd=SCRIPT.parent.parent
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    for section in ("tool executor overhead benchmark", "Case 1: one call", "Case 2: throughput", "Targets"):
        assert section in proc.stdout, proc.stdout
    assert "8 tasks, async tool (acall)" in proc.stdout
