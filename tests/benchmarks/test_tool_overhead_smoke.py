"""Smoke test: ``benchmarks/tool_overhead.py --quick`` runs to the end and prints its table (no timing checks)."""

from .script import table


def test_quick_run_prints_the_table() -> None:
    out = table("tool_overhead.py", "--quick")
    for section in (
        "tool executor overhead benchmark",
        "Case 1: one call",
        "Case 2: throughput",
        "Case 3: one call by output size",
        "Targets",
    ):
        assert section in out, out
    assert "8 tasks, async tool (acall)" in out
