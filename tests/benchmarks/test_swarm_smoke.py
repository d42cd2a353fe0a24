"""Smoke test: ``benchmarks/swarm.py --quick`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "swarm.py"


def test_quick_run_prints_the_table() -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick", "--uavs", "6", "--tasks", "10"],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=SCRIPT.parent.parent,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = (
        "allocation time (median)",
        "optimality gap",
        "over A2A on 127.0.0.1, 2 UAVs",
        "deconflicted legs",
        "lockstep physics, 4",
        "lockstep MAVLink vehicles, 4",
    )
    for row in rows:
        assert row in proc.stdout, proc.stdout
