"""Smoke test: ``benchmarks/sim_speed.py --quick`` runs to the end and prints both measured cases."""

import re
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "sim_speed.py"


def test_quick_run_prints_the_ratios():
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"], capture_output=True, text=True, timeout=120, cwd=SCRIPT.parent.parent
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "simulator speed benchmark" in proc.stdout
    rates = re.findall(r"^\((a|b)\).*?(\d+)x$", proc.stdout, flags=re.MULTILINE)
    assert [case for case, _ in rates] == ["a", "b"], proc.stdout
    assert all(int(rate) > 1 for _, rate in rates), proc.stdout  # both faster than real time
    assert "ratio (b)/(a):" in proc.stdout
