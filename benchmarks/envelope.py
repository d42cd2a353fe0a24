"""The flight envelope's cost per command, beside the tools executor's own overhead per call (issue 15's target:
under 50 µs a command). Prints a table; ``--quick`` for a short run.

    python benchmarks/envelope.py [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable
from functools import partial
from typing import Any

from agentic_core.agent.envelope import Envelope
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.policy_graph import Limits
from tools import Caller, ToolExecutor, ToolRegistry
from tools.function import spec_from_function

HOME = (21.4133, 39.8933)
TARGET_US = 50.0


def _noop(north_m: float = 0.0) -> float:
    """A tool that does nothing: the executor's own cost."""
    return north_m


def per_call_us(fn: Callable[[], Any], n: int, rounds: int = 5) -> float:
    """The median over ``rounds`` of the mean time of one call, in microseconds."""
    means = []
    for _ in range(rounds):
        start = time.perf_counter()
        for _ in range(n):
            fn()
        means.append((time.perf_counter() - start) / n * 1e6)
    return statistics.median(means)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer calls")
    n = 300 if parser.parse_args().quick else 5_000
    circle = Limits.model_validate(
        {"geofence": {"center": {"lat": HOME[0], "lon": HOME[1]}, "radius_m": 800}, "max_altitude_m": 60}
    )
    corners = [offset_position(*HOME, 500 * dn, 500 * de) for dn, de in ((-1, -1), (-1, 1), (1, 1), (1, -1))]
    square = Limits.model_validate({"geofence": [{"lat": a, "lon": b} for a, b in corners], "max_altitude_m": 60})
    lat, lon = offset_position(*HOME, 120.0, 40.0)
    targets = {"P-12": (lat, lon)}
    rows: list[tuple[str, float]] = []
    commands: list[tuple[str, str, dict[str, Any]]] = [
        ("fly_to north/east", "flight.fly_to", {"north_m": 120.0, "east_m": 40.0, "alt_m": 30.0}),
        ("fly_to lat/lon", "flight.fly_to", {"lat": lat, "lon": lon, "alt_m": 30.0}),
        ("fly_to target_id", "flight.fly_to", {"target_id": "P-12", "alt_m": 30.0}),
        ("orbit (the whole circle)", "flight.orbit", {"target_id": "P-12", "radius_m": 20.0}),
    ]
    for name, limits in (("circle fence", circle), ("polygon fence", square)):
        env = Envelope(limits, home=lambda: HOME, targets=targets.get)
        for label, tool, args in commands:
            rows.append((f"{label}, {name}", per_call_us(partial(env.check, tool, args), n)))
    registry = ToolRegistry()
    registry.register(spec_from_function(_noop, name="bench.noop", scopes=[]))
    executor = ToolExecutor(registry, default_caller=Caller(id="bench"))
    executor_us = per_call_us(lambda: executor.call("bench.noop", {"north_m": 1.0}), n)
    executor.close()
    print("flight envelope: cost of one check (median of 5 rounds of", n, "calls)")
    print(f"{'command':<46} {'µs/check':>9}  target < {TARGET_US:g} µs")
    for name, us in rows:
        print(f"{name:<46} {us:9.1f}  {'PASS' if us < TARGET_US else 'MISS'}")
    print(f"{'(beside it) tools executor, one no-op call':<46} {executor_us:9.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
