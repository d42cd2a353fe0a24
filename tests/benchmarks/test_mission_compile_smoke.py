"""Smoke test: ``benchmarks/mission_compile.py --steps 50`` runs to the end and prints its table (no timing checks)."""

import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "mission_compile.py"


def test_small_run_prints_the_table(tmp_path: Path) -> None:
    kept = tmp_path / "mission.yaml"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), "--steps", "50", "--runs", "2", "--keep", str(kept)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = proc.stdout.splitlines()
    assert lines[0] == "mission load/validate/compile benchmark"
    assert lines[1].startswith("50 steps (+")
    for row in ("load + validate (load_mission)", "compile (compile_mission)", "total (load + validate + compile)"):
        assert any(line.startswith(row) for line in lines), proc.stdout
    assert lines[-1].startswith("target: total < 100 ms -> ")
    assert lines[-1].split(" -> ")[1].split()[0] in ("PASS", "MISS")
    assert kept.read_text(encoding="utf-8").startswith("plan_id: bench-50\n")


def test_too_few_steps_is_a_usage_error() -> None:
    proc = subprocess.run([sys.executable, str(SCRIPT), "--steps", "2"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert "--steps must be at least 3" in proc.stderr
