"""Smoke test: ``benchmarks/envelope.py --quick`` runs to the end and prints its table (no timing checks)."""

from .script import table


def test_quick_run_prints_the_table() -> None:
    out = table("envelope.py", "--quick")
    for row in ("fly_to north/east, polygon fence", "orbit (the whole circle), circle fence", "tools executor"):
        assert row in out, out
