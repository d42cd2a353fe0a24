"""What the guarded tool executor costs over calling a tool directly.

Case 1 times one call through the full executor path (lookup, jsonschema argument validation, scopes, rate limit,
breaker, timeout, output validation, injection guard, audit record, ToolResult) for a no-op tool with one argument,
against calling the function itself; the overhead is the difference of medians over ``--repeats`` batches.
Variants:

* ``sync, default`` — a sync tool with the default 30 s timeout: it runs on the caller's worker thread so the
  caller can stop waiting (a thread hand-off per call);
* ``sync, timeout_s=None`` — the same tool run inline in the caller's thread;
* ``async via acall`` — an async tool awaited under ``asyncio.timeout``;
* ``sync, all guards`` — scopes, a per-tool and per-caller rate limit, and a JSONL audit file.

Case 2 counts calls per second with 8 concurrent callers (8 threads on ``call``; 8 tasks on ``acall``).
Case 3 gives the time and the executor's memory peak (tracemalloc, over the output the tool made) for one call by
output size, prose text from 10 kB up to just under the 1 MiB bound and 8 MiB over it (an error result).
Target: under 50 µs of overhead per call on the default path.

Case 1 runs twice: as the OS schedules it, and again in a child process pinned to one CPU (Linux). On a VM,
waking a thread on an idle second vCPU costs 80–160 µs, against about 9 µs on one CPU; the pinned column shows
what the executor itself costs, the first what a caller on such a machine sees.

Usage: ``python benchmarks/tool_overhead.py [--calls 20000] [--repeats 5] [--quick]``. Exit status 0 whether the
target is met or not (``--strict``: 1 on MISS).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO_ROOT = Path(__file__).resolve().parent.parent
if str(REPO_ROOT) not in sys.path:
    sys.path.insert(0, str(REPO_ROOT))

from tools import Caller, JsonlAuditLog, ToolExecutor, ToolRegistry, ToolSpec  # noqa: E402

TABLE_HEADER = "tool executor overhead benchmark"
TARGET_US = 50.0
CALLER = Caller(id="bench", scopes=frozenset({"bench:*"}))


def noop(x: int) -> int:
    """Return x."""
    return x


async def anoop(x: int) -> int:
    """Return x."""
    return x


def _registry() -> ToolRegistry:
    registry = ToolRegistry()
    registry.tool(name="bench.sync")(noop)
    registry.tool(name="bench.inline", timeout_s=None)(_copy(noop))
    registry.tool(name="bench.async")(anoop)
    registry.tool(name="bench.guarded", scopes=["bench:run"], rate_limit="1000000/s", caller_rate_limit="1000000/s")(
        _copy(noop)
    )
    return registry


def _copy(fn: Callable[[int], int]) -> Callable[[int], int]:
    def copy(x: int) -> int:
        return fn(x)

    copy.__doc__ = fn.__doc__
    return copy


def _per_call_us(run: Callable[[int], None], calls: int, repeats: int) -> float:
    run(max(100, calls // 10))  # warm-up
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        run(calls)
        samples.append((time.perf_counter() - start) / calls * 1e6)
    return statistics.median(samples)


def case_overhead(calls: int, repeats: int, audit_dir: Path) -> list[tuple[str, float, float]]:
    registry = _registry()
    executor = ToolExecutor(registry, default_caller=CALLER)
    guarded = ToolExecutor(registry, default_caller=CALLER, audit=JsonlAuditLog(audit_dir / "audit.jsonl"))

    def direct(n: int) -> None:
        for i in range(n):
            noop(i)

    def through(tool: str, on: ToolExecutor) -> Callable[[int], None]:
        def run(n: int) -> None:
            for i in range(n):
                result = on.call(tool, {"x": i})
            assert result.status == "ok", result

        return run

    def through_async(n: int) -> None:
        async def go() -> None:
            for i in range(n):
                result = await executor.acall("bench.async", {"x": i})
            assert result.status == "ok", result

        asyncio.run(go())

    def direct_async(n: int) -> None:
        async def go() -> None:
            for i in range(n):
                await anoop(i)

        asyncio.run(go())

    base = _per_call_us(direct, calls, repeats)
    base_async = _per_call_us(direct_async, calls, repeats)
    rows = []
    for label, run, ref in (
        ("sync, default (30 s timeout)", through("bench.sync", executor), base),
        ("sync, timeout_s=None (inline)", through("bench.inline", executor), base),
        ("async via acall", through_async, base_async),
        ("sync, all guards + JSONL audit", through("bench.guarded", guarded), base),
    ):
        total = _per_call_us(run, calls, repeats)
        rows.append((label, total, total - ref))
    executor.close()
    guarded.close()
    return rows


def case_concurrency(calls: int) -> list[tuple[str, float]]:
    registry = _registry()
    executor = ToolExecutor(registry, default_caller=CALLER)
    per_worker = max(1, calls // 8)

    def threads(tool: str) -> float:
        barrier = threading.Barrier(9)

        def work() -> None:
            barrier.wait()
            for i in range(per_worker):
                executor.call(tool, {"x": i})

        workers = [threading.Thread(target=work) for _ in range(8)]
        for worker in workers:
            worker.start()
        barrier.wait()
        start = time.perf_counter()
        for worker in workers:
            worker.join()
        return 8 * per_worker / (time.perf_counter() - start)

    def tasks() -> float:
        async def go() -> float:
            async def work() -> None:
                for i in range(per_worker):
                    await executor.acall("bench.async", {"x": i})

            start = time.perf_counter()
            await asyncio.gather(*(work() for _ in range(8)))
            return 8 * per_worker / (time.perf_counter() - start)

        return asyncio.run(go())

    rows = [
        ("8 threads, sync tool (default)", threads("bench.sync")),
        ("8 threads, sync tool (inline)", threads("bench.inline")),
        ("8 tasks, async tool (acall)", tasks()),
    ]
    executor.close()
    return rows


def case_output_size(quick: bool) -> list[tuple[str, float, float]]:
    """(output, ms per call, executor's peak / output size) for prose outputs of growing size."""
    registry = ToolRegistry()
    answer: dict[str, Any] = {}
    registry.register(ToolSpec.from_schema("bench.output", lambda args: answer["value"], {"type": "object"}))
    executor = ToolExecutor(registry, default_caller=CALLER)
    line = "wind 12 kt from 320, gusts 20; visibility good; "
    sizes = (10_000, 100_000) if quick else (10_000, 100_000, 1_000_000, 8 * 1024 * 1024)
    rows = []
    for size in sizes:
        answer["value"] = {"text": (line * (size // len(line) + 1))[:size]}
        tracemalloc.start()
        base = tracemalloc.get_traced_memory()[0]
        start = time.perf_counter()
        result = executor.call("bench.output", {})
        elapsed = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1] - base
        tracemalloc.stop()
        label = f"{size / 1e6:.2f} MB of text ({'ok' if result.ok else 'refused'})"
        rows.append((label, elapsed * 1e3, peak / size))
    executor.close()
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--calls", type=int, default=20_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--quick", action="store_true", help="a short run (smoke test)")
    parser.add_argument("--strict", action="store_true", help="exit 1 when the target is missed")
    parser.add_argument("--pinned-case-1", action="store_true", help=argparse.SUPPRESS)  # the pinned child run
    args = parser.parse_args(argv)
    calls, repeats = (500, 2) if args.quick else (args.calls, args.repeats)
    if args.pinned_case_1:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        with tempfile.TemporaryDirectory() as folder:
            print(json.dumps(case_overhead(calls, repeats, Path(folder))))
        return 0

    print(f"{TABLE_HEADER} (Python {sys.version.split()[0]}, {calls} calls x {repeats} batches)")
    with tempfile.TemporaryDirectory() as folder:
        overhead = case_overhead(calls, repeats, Path(folder))
    pinned = _pinned(calls, repeats)
    print("\nCase 1: one call, median per call (overhead = through the executor minus a direct call)")
    print(f"  {'path':<34} {'total µs':>10} {'overhead µs':>12} {'pinned: overhead µs':>20}")
    for i, (label, total, extra) in enumerate(overhead):
        other = f"{pinned[i][2]:.1f}" if pinned else "n/a"
        print(f"  {label:<34} {total:>10.1f} {extra:>12.1f} {other:>20}")
    print("\nCase 2: throughput with 8 concurrent callers")
    for label, rate in case_concurrency(calls):
        print(f"  {label:<34} {rate:>10,.0f} calls/s")
    print("\nCase 3: one call by output size (the executor's tracemalloc peak over the output's own size)")
    print(f"  {'output':<34} {'ms':>10} {'peak / size':>12}")
    for label, ms, ratio in case_output_size(args.quick):
        print(f"  {label:<34} {ms:>10.1f} {ratio:>11.1f}x")
    default_overhead = overhead[0][2]
    met = default_overhead < TARGET_US
    print("\nTargets")
    print(f"  overhead on the default path < {TARGET_US:g} µs: {default_overhead:.1f} µs  {'PASS' if met else 'MISS'}")
    if pinned:
        verdict = "PASS" if pinned[0][2] < TARGET_US else "MISS"
        print(f"  the same, pinned to one CPU:            {pinned[0][2]:.1f} µs  {verdict}")
    return 1 if args.strict and not met else 0


def _pinned(calls: int, repeats: int) -> list[list[Any]] | None:
    """Case 1 in a child process pinned to one CPU; None where the OS cannot pin."""
    if not hasattr(os, "sched_setaffinity"):
        return None
    child = [sys.executable, __file__, "--pinned-case-1", "--calls", str(calls), "--repeats", str(repeats)]
    proc = subprocess.run(child, capture_output=True, text=True, timeout=1800, check=True)
    rows: list[list[Any]] = json.loads(proc.stdout)
    return rows


if __name__ == "__main__":
    sys.exit(main())
