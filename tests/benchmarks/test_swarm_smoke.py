"""Smoke test: ``benchmarks/swarm.py --quick`` runs to the end and prints its table (no timing checks)."""

from .script import table


def test_quick_run_prints_the_table() -> None:
    out = table("swarm.py", "--quick", "--uavs", "6", "--tasks", "10")
    rows = (
        "allocation time (median)",
        "optimality gap",
        "over A2A on 127.0.0.1, 2 UAVs",
        "deconflicted legs",
        "lockstep physics, 4",
        "lockstep MAVLink vehicles, 4",
    )
    for row in rows:
        assert row in out, out
