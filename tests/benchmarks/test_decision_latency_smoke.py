"""Smoke test: ``benchmarks/decision_latency.py --quick`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "decision_latency.py"


def test_quick_run_prints_every_stage_for_both_reasoners(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--quick"], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0] == "decision latency benchmark (our overhead, detection frame to alert)"
    assert "rules" in lines[1] and "llm (stand-in, 0 s)" in lines[1]
    stages = [line.rsplit(maxsplit=2)[0] for line in lines[2:10]]
    assert stages == [
        "detector (simulated)", "model server (stand-in)", "perception", "trigger", "assess", "mission", "attach",
        "alert",
    ]  # fmt: skip
    server = [float(v) for v in lines[3].split()[-2:]]
    assert server[0] == 0.0 and server[1] > 0.0  # the rules ask no model; the stand-in says how long it worked
    assert any(line.startswith("not counted: detector (simulated), model server (stand-in)") for line in lines)
    verdicts = [line for line in lines if line.startswith("total, ")]
    assert len(verdicts) == 2 and all(line.rsplit(": ", 1)[1] in ("PASS", "MISS") for line in verdicts)
