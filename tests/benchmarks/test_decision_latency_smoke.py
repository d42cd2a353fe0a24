"""Smoke test: ``benchmarks/decision_latency.py --quick`` runs to the end and prints its table (no timing checks)."""

from pathlib import Path

import pytest

from .script import table


@pytest.mark.slow
def test_quick_run_prints_every_stage_for_both_reasoners(tmp_path: Path) -> None:
    out = table("decision_latency.py", "--quick", cwd=tmp_path)
    lines = out.splitlines()
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
