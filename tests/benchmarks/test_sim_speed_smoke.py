"""Smoke test: ``benchmarks/sim_speed.py --quick`` runs to the end and prints all three cases, the ratios and a verdict
on each target (no timing checks: the machine may be busy)."""

import re

from .script import table


def test_quick_run_prints_the_cases_ratios_and_targets():
    out = table("sim_speed.py", "--quick", timeout_s=180)
    assert "simulator speed benchmark" in out
    rates = re.findall(r"^\((a|b|c)\).*?\s(\d+)x\s", out, flags=re.MULTILINE)
    assert [case for case, _ in rates] == ["a", "b", "c"], out
    assert all(int(rate) > 1 for _, rate in rates), out  # all faster than real time
    assert "ratio (b)/(a):" in out and "ratio (c)/(a):" in out
    # The ground station in the other process received the streams (the count is a share of what was promised).
    share = re.search(r"telemetry in \(c\): the client received (\d+) of (\d+) streamed messages", out)
    assert share is not None and int(share.group(1)) > 0, out
    verdicts = re.findall(r"^  \(c\) >= .*: (PASS|MISS) ", out, flags=re.MULTILINE)
    assert len(verdicts) == 2, out
