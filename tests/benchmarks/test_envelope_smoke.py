"""Smoke test: ``benchmarks/envelope.py --quick`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "envelope.py"


def test_quick_run_prints_the_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"], capture_output=True, text=True, timeout=300, cwd=SCRIPT.parent.parent
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    for row in ("fly_to north/east, polygon fence", "orbit (the whole circle), circle fence", "tools executor"):
        assert row in proc.stdout, proc.stdout
