"""Smoke test: ``benchmarks/graph_overhead.py --quick`` runs to the end and prints its table (no timing checks)."""

import pytest

from .script import table


@pytest.mark.slow
def test_quick_run_prints_the_table() -> None:
    out = table("graph_overhead.py", "--quick", timeout_s=600)
    assert "agentic_core.graph overhead benchmark" in out
    for section in ("Case 1: per-superstep overhead", "Case 2: checkpoint growth", "Case 3: import time", "Targets"):
        assert section in out, out
