"""Smoke test: ``benchmarks/mission_compile.py --steps 50`` runs to the end and prints its table (no timing checks)."""

from pathlib import Path

from .script import run_script, table


def test_small_run_prints_the_table(tmp_path: Path) -> None:
    kept = tmp_path / "mission.yaml"
    out = table("mission_compile.py", "--steps", "50", "--runs", "2", "--keep", str(kept), cwd=tmp_path)
    lines = out.splitlines()
    assert lines[0] == "mission load/validate/compile benchmark"
    assert lines[1].startswith("50 steps (+")
    for row in ("load + validate (load_mission)", "compile (compile_mission)", "total (load + validate + compile)"):
        assert any(line.startswith(row) for line in lines), out
    assert lines[-1].startswith("target: total < 100 ms -> ")
    assert lines[-1].split(" -> ")[1].split()[0] in ("PASS", "MISS")
    assert kept.read_text(encoding="utf-8").startswith("plan_id: bench-50\n")


def test_too_few_steps_is_a_usage_error() -> None:
    proc = run_script("mission_compile.py", "--steps", "2", timeout_s=120)
    assert proc.returncode == 2
    assert "--steps must be at least 3" in proc.stderr
