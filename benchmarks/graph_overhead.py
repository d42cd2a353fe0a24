"""Runtime overhead of ``agentic_core.graph`` beside LangGraph: per superstep, checkpoint growth, import time.

Run ``python benchmarks/graph_overhead.py`` (or ``make bench``). Every measurement runs in a fresh child process
(this script re-invoked with ``--child ...``, printing one JSON line), and the table reports medians over
``--runs`` processes, so one noisy neighbour on a shared machine moves a run, not the result.

Cases:

1. Per-superstep overhead: START -> inc -> check -> (router) inc ... until ``count == --steps``, then END
   (``2 * steps`` supersteps), without a checkpointer, with the in-memory one and with SQLite (a temp file).
   The timed call is one ``invoke()`` after a short warm-up ``invoke()`` on a separate saver in the same process.
2. Checkpoint growth: one item appended per superstep to an ``Annotated[list, operator.add]`` key with the
   in-memory checkpointer; tracemalloc peak and ru_maxrss growth (separate processes, since tracing inflates
   RSS) and the saver's serialized bytes, at 1/4, 1/2 and all of ``--steps``.
3. Import time of ``agentic_core.graph``: wall time of ``python -c "import agentic_core.graph"`` minus wall time
   of ``python -c "pass"`` (interleaved, medians), with ``python -X importtime``'s cumulative figure beside it.

``--profile MODE`` instead runs case 1 for our runtime in this process under cProfile and prints the functions
that dominate a superstep.
"""

import argparse
import cProfile
import importlib
import importlib.metadata
import importlib.util
import json
import operator
import os
import platform
import pstats
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, TypedDict

REPO_ROOT = Path(__file__).resolve().parent.parent
TABLE_HEADER = "agentic_core.graph overhead benchmark"
MODES = ("none", "memory", "sqlite")
MODE_LABELS = {"none": "no checkpointer", "memory": "in-memory", "sqlite": "SQLite (temp file)"}
IMPLS = ("ours", "langgraph")
SPEEDUP_TARGET = 10.0
IMPORT_TARGET_MS = 150.0
LINEAR_MAX_GROWTH = 2.5  # doubling the steps may at most multiply memory by this (linear ~2x, quadratic ~4x)
LANGGRAPH_REFERENCE_MIB = 50.0
WARMUP_STEPS = 5
CHILD_TIMEOUT_S = 1800.0
MIB = 1024.0 * 1024.0


# --- the graphs (module level, so both runtimes can resolve the TypedDict annotations) ---
class LoopState(TypedDict):
    count: int


class AppendState(TypedDict):
    items: Annotated[list[dict[str, Any]], operator.add]


def graph_module(impl: str) -> Any:
    """``agentic_core.graph`` or ``langgraph.graph``: both expose StateGraph, START and END."""
    return importlib.import_module("agentic_core.graph" if impl == "ours" else "langgraph.graph")


def build_loop_graph(impl: str, target: int) -> Any:
    """START -> inc -> check -> (inc | END): two supersteps per increment."""
    g = graph_module(impl)

    def inc(state: LoopState) -> dict[str, Any]:
        return {"count": state["count"] + 1}

    def check(state: LoopState) -> None:
        return None

    def route(state: LoopState) -> str:
        return "inc" if state["count"] < target else str(g.END)

    builder = g.StateGraph(LoopState)
    builder.add_node("inc", inc)
    builder.add_node("check", check)
    builder.add_edge(g.START, "inc")
    builder.add_edge("inc", "check")
    builder.add_conditional_edges("check", route)
    return builder


def telemetry_item(i: int) -> dict[str, Any]:
    """One appended item: a small UAV log record."""
    return {
        "step": i,
        "event": "waypoint_reached",
        "lat": 47.397742 + i * 1e-6,
        "lon": 8.545594 - i * 1e-6,
        "alt_m": 10.0 + i % 7,
    }


def build_append_graph(impl: str, target: int) -> Any:
    """START -> append -> (append | END): one item per superstep until ``target`` items."""
    g = graph_module(impl)

    def append(state: AppendState) -> dict[str, Any]:
        return {"items": [telemetry_item(len(state["items"]))]}

    def route(state: AppendState) -> str:
        return "append" if len(state["items"]) < target else str(g.END)

    builder = g.StateGraph(AppendState)
    builder.add_node("append", append)
    builder.add_edge(g.START, "append")
    builder.add_conditional_edges("append", route)
    return builder


# --- savers ---
def make_saver(impl: str, mode: str, workdir: Path, tag: str) -> Any:
    if mode == "none":
        return None
    if impl == "ours":
        from agentic_core.graph import InMemorySaver, SqliteSaver

        return InMemorySaver() if mode == "memory" else SqliteSaver(workdir / f"ours-{tag}.sqlite")
    if mode == "memory":
        return importlib.import_module("langgraph.checkpoint.memory").InMemorySaver()
    import sqlite3

    lg_sqlite = importlib.import_module("langgraph.checkpoint.sqlite")
    conn = sqlite3.connect(str(workdir / f"langgraph-{tag}.sqlite"), check_same_thread=False)
    return lg_sqlite.SqliteSaver(conn)


def storage_bytes(impl: str, saver: Any) -> int:
    """Serialized checkpoint bytes held by an in-memory saver (LangGraph's has no such method: sum its dicts)."""
    if impl == "ours":
        return int(saver.storage_bytes())
    total = 0
    for per_ns in saver.storage.values():
        for per_id in per_ns.values():
            for checkpoint, metadata, _parent in per_id.values():
                total += len(checkpoint[1]) + len(metadata[1])
    for _type, blob in saver.blobs.values():
        total += len(blob)
    for per_task in saver.writes.values():
        for write in per_task.values():
            total += len(write[2][1])
    return total


def run_config(target_supersteps: int) -> dict[str, Any]:
    return {"configurable": {"thread_id": "bench"}, "recursion_limit": target_supersteps + 10}


def maxrss_bytes() -> int:
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return int(rss if sys.platform == "darwin" else rss * 1024)


# --- child processes (each prints one JSON object) ---
def child_superstep(impl: str, mode: str, steps: int) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="graph-overhead-") as tmp:
        workdir = Path(tmp)
        warm = build_loop_graph(impl, WARMUP_STEPS).compile(checkpointer=make_saver(impl, mode, workdir, "warmup"))
        warm.invoke({"count": 0}, run_config(2 * WARMUP_STEPS))
        graph = build_loop_graph(impl, steps).compile(checkpointer=make_saver(impl, mode, workdir, "timed"))
        config = run_config(2 * steps)
        t0 = time.perf_counter()
        out = graph.invoke({"count": 0}, config)
        seconds = time.perf_counter() - t0
    if out["count"] != steps:
        raise RuntimeError(f"{impl}/{mode}: expected count {steps}, got {out['count']}")
    return {"seconds": seconds, "supersteps": 2 * steps}


def child_append(impl: str, steps: int, method: str) -> dict[str, Any]:
    with tempfile.TemporaryDirectory(prefix="graph-overhead-") as tmp:
        workdir = Path(tmp)
        warm = build_append_graph(impl, WARMUP_STEPS).compile(
            checkpointer=make_saver(impl, "memory", workdir, "warmup")
        )
        warm.invoke({"items": []}, run_config(WARMUP_STEPS))
        del warm
        saver = make_saver(impl, "memory", workdir, "measured")
        graph = build_append_graph(impl, steps).compile(checkpointer=saver)
        config = run_config(steps)
        result: dict[str, Any] = {}
        if method == "tracemalloc":
            tracemalloc.start()
            out = graph.invoke({"items": []}, config)
            current, peak = tracemalloc.get_traced_memory()
            tracemalloc.stop()
            result.update(peak_bytes=peak, retained_bytes=current)
        else:
            rss0 = maxrss_bytes()
            out = graph.invoke({"items": []}, config)
            result.update(maxrss_delta_bytes=maxrss_bytes() - rss0, maxrss_bytes=maxrss_bytes())
        result["storage_bytes"] = storage_bytes(impl, saver)
    if len(out["items"]) != steps:
        raise RuntimeError(f"{impl}: expected {steps} items, got {len(out['items'])}")
    return result


def child_main(args: argparse.Namespace) -> None:
    if args.child == "superstep":
        result = child_superstep(args.impl, args.mode, args.steps)
    elif args.child == "append":
        result = child_append(args.impl, args.steps, args.method)
    else:
        raise SystemExit(f"unknown child kind {args.child!r}")
    print(json.dumps(result))


# --- the parent ---
def child_env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO_ROOT), env.get("PYTHONPATH", "")) if p)
    return env


def spawn(child_args: Sequence[str]) -> dict[str, Any]:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", *child_args]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=child_env(), cwd=REPO_ROOT, timeout=CHILD_TIMEOUT_S)
    if proc.returncode != 0:
        raise RuntimeError(f"child {' '.join(child_args)} failed ({proc.returncode}):\n{proc.stderr[-3000:]}")
    lines = proc.stdout.strip().splitlines()
    parsed: dict[str, Any] = json.loads(lines[-1])
    return parsed


def available(module: str) -> str | None:
    """None when ``module`` can be imported, else why not."""
    try:
        spec = importlib.util.find_spec(module)
    except (ImportError, ValueError) as exc:
        return f"{type(exc).__name__}: {exc}"
    return None if spec is not None else f"No module named {module!r}"


def version_of(dist: str) -> str:
    try:
        return importlib.metadata.version(dist)
    except importlib.metadata.PackageNotFoundError:
        return "not installed"


def fmt_bytes(n: float) -> str:
    return f"{n / MIB:8.2f} MiB" if abs(n) >= 0.1 * MIB else f"{n / 1024.0:8.1f} KiB"


def progress(msg: str) -> None:
    print(f"  .. {msg}", file=sys.stderr, flush=True)


@dataclass
class Target:
    name: str
    measured: str
    verdict: str  # PASS, MISS or SKIP


@dataclass
class Report:
    targets: list[Target] = field(default_factory=list)

    def add(self, name: str, measured: str, ok: bool | None) -> None:
        self.targets.append(Target(name, measured, "SKIP" if ok is None else "PASS" if ok else "MISS"))


def case_superstep(runs: int, steps: int, lg_reason: str | None, report: Report) -> None:
    sqlite_reason = lg_reason or available("langgraph.checkpoint.sqlite")
    if sqlite_reason is not None and lg_reason is None:
        sqlite_reason = f"package langgraph-checkpoint-sqlite is not installed ({sqlite_reason})"
    jobs: list[tuple[str, str]] = []
    for mode in MODES:
        jobs.append(("ours", mode))
        if lg_reason is None and not (mode == "sqlite" and sqlite_reason is not None):
            jobs.append(("langgraph", mode))
    samples: dict[tuple[str, str], list[float]] = {job: [] for job in jobs}
    for r in range(runs):  # interleaved, so slow spells on a shared machine hit every column alike
        for impl, mode in jobs:
            progress(f"case 1 run {r + 1}/{runs}: {impl} / {mode}")
            res = spawn(["superstep", "--impl", impl, "--mode", mode, "--steps", str(steps)])
            samples[(impl, mode)].append(float(res["seconds"]))
    supersteps = 2 * steps
    print()
    print(f"Case 1: per-superstep overhead — START→inc→check→(inc|END) to count={steps} ({supersteps} supersteps);")
    print(f"        one invoke() after a warm-up invoke, median of {runs} fresh process(es)")
    head = f"  {'mode':<20}{'ours s':>9}{'ours µs/step':>14}{'LangGraph s':>13}{'LG µs/step':>12}{'LG/ours':>9}"
    print(head)
    print("  " + "-" * (len(head) - 2))
    for mode in MODES:
        ours = samples[("ours", mode)]
        o_med = statistics.median(ours)
        row = f"  {MODE_LABELS[mode]:<20}{o_med:>9.4f}{o_med / supersteps * 1e6:>14.1f}"
        lg = samples.get(("langgraph", mode))
        name = f"per-superstep ≥{SPEEDUP_TARGET:.0f}× faster than LangGraph, {MODE_LABELS[mode]}"
        if lg:
            l_med = statistics.median(lg)
            ratio = l_med / o_med
            row += f"{l_med:>13.4f}{l_med / supersteps * 1e6:>12.1f}{ratio:>8.1f}×"
            report.add(
                name,
                f"{ratio:.1f}× ({o_med / supersteps * 1e6:.1f} vs {l_med / supersteps * 1e6:.1f} µs)",
                ratio >= SPEEDUP_TARGET,
            )
        else:
            why = lg_reason if lg_reason is not None else sqlite_reason
            row += f"   LangGraph row skipped: {why}"
            report.add(name, "LangGraph row skipped", None)
        print(row)
        spread = f"ours {min(ours):.4f}–{max(ours):.4f} s"
        if lg:
            spread += f", LangGraph {min(lg):.4f}–{max(lg):.4f} s"
        print(f"    range: {spread}")


def case_append(runs: int, steps: int, lg_reason: str | None, report: Report) -> None:
    points = sorted({max(1, steps // 4), max(1, steps // 2), steps})
    impls = [i for i in IMPLS if i == "ours" or lg_reason is None]
    trace: dict[tuple[str, int], list[dict[str, Any]]] = {(i, n): [] for i in impls for n in points}
    rss: dict[tuple[str, int], list[dict[str, Any]]] = {(i, n): [] for i in impls for n in points}
    for r in range(runs):
        for n in points:
            for impl in impls:
                progress(f"case 2 run {r + 1}/{runs}: {impl} / {n} steps")
                base = ["append", "--impl", impl, "--steps", str(n)]
                trace[(impl, n)].append(spawn([*base, "--method", "tracemalloc"]))
                rss[(impl, n)].append(spawn([*base, "--method", "rss"]))

    def med(bucket: dict[tuple[str, int], list[dict[str, Any]]], impl: str, n: int, key: str) -> float:
        return float(statistics.median(float(x[key]) for x in bucket[(impl, n)]))

    print()
    print("Case 2: checkpoint growth — one item per superstep appended to Annotated[list, operator.add],")
    print(f"        in-memory checkpointer, median of {runs} fresh process(es) per cell")
    print("        tracemalloc peak/retained: Python allocations during invoke() (tracing on);")
    print("        ru_maxrss Δ: growth of the process's peak RSS across invoke() (separate process, no tracing);")
    print("        storage: serialized bytes held by the saver (LangGraph: checkpoints + blobs + writes)")
    head = (
        f"  {'steps':>6}  {'impl':<10}{'tracemalloc peak':>17}{'retained':>14}{'ru_maxrss Δ':>14}"
        f"{'storage':>14}{'bytes/step':>12}"
    )
    print(head)
    print("  " + "-" * (len(head) - 2))
    for impl in impls:
        for n in points:
            peak = med(trace, impl, n, "peak_bytes")
            kept = med(trace, impl, n, "retained_bytes")
            grown = med(rss, impl, n, "maxrss_delta_bytes")
            stored = med(trace, impl, n, "storage_bytes")
            print(
                f"  {n:>6}  {impl:<10}{fmt_bytes(peak):>17}{fmt_bytes(kept):>14}{fmt_bytes(grown):>14}"
                f"{fmt_bytes(stored):>14}{stored / n:>12.0f}"
            )
    half, full = points[-2] if len(points) > 1 else points[0], points[-1]
    growth_peak = med(trace, "ours", full, "peak_bytes") / med(trace, "ours", half, "peak_bytes")
    growth_store = med(trace, "ours", full, "storage_bytes") / med(trace, "ours", half, "storage_bytes")
    print(
        f"  ours, {half}→{full} steps: tracemalloc peak ×{growth_peak:.2f}, storage ×{growth_store:.2f}"
        f" (linear ≈ ×{full / half:.1f}, quadratic ≈ ×{(full / half) ** 2:.1f})"
    )
    if "langgraph" in impls:
        lg_peak = med(trace, "langgraph", full, "peak_bytes") / med(trace, "langgraph", half, "peak_bytes")
        lg_store = med(trace, "langgraph", full, "storage_bytes") / med(trace, "langgraph", half, "storage_bytes")
        print(f"  LangGraph, {half}→{full} steps: tracemalloc peak ×{lg_peak:.2f}, storage ×{lg_store:.2f}")
    limit = LINEAR_MAX_GROWTH * (full / half) / 2.0
    ours_full = med(trace, "ours", full, "peak_bytes")
    measured = f"peak ×{growth_peak:.2f}, storage ×{growth_store:.2f} per {full / half:.0f}× steps"
    measured += f"; {fmt_bytes(ours_full).strip()} peak at {full}"
    if "langgraph" in impls:
        lg_full = med(trace, "langgraph", full, "peak_bytes")
        measured += f" (LangGraph {fmt_bytes(lg_full).strip()}; ref ~{LANGGRAPH_REFERENCE_MIB:.0f} MiB at 1000)"
    report.add(
        f"append-case memory linear in steps (≤ ×{limit:.1f} when steps ×{full / half:.0f})",
        measured,
        growth_peak <= limit and growth_store <= limit if full > half else None,
    )


def time_command(code: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", code], check=True, env=child_env(), cwd=REPO_ROOT)
    return time.perf_counter() - t0


def importtime_us(module: str) -> float:
    """Cumulative microseconds ``python -X importtime`` reports for ``module``."""
    proc = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", f"import {module}"],
        capture_output=True,
        text=True,
        check=True,
        env=child_env(),
        cwd=REPO_ROOT,
    )
    for line in proc.stderr.splitlines():
        parts = [p.strip() for p in line.removeprefix("import time:").split("|")]
        if len(parts) == 3 and parts[2] == module:
            return float(parts[1])
    raise RuntimeError(f"-X importtime printed no line for {module}")


def case_import(samples: int, lg_reason: str | None, report: Report) -> None:
    modules = ["agentic_core.graph"] + (["langgraph.graph"] if lg_reason is None else [])
    wall: dict[str, list[float]] = {m: [] for m in ["", *modules]}
    xtime: dict[str, list[float]] = {m: [] for m in modules}
    for r in range(samples):
        progress(f"case 3 sample {r + 1}/{samples}")
        wall[""].append(time_command("pass"))
        for m in modules:
            wall[m].append(time_command(f"import {m}"))
            xtime[m].append(importtime_us(m))
    base = statistics.median(wall[""])
    print()
    print("Case 3: import time in a fresh process, median of", samples)
    print('        wall: `python -c "import M"` minus `python -c "pass"` (interleaved);')
    print("        -X importtime: the cumulative figure Python reports for M itself")
    head = f"  {'module':<22}{'wall ms':>10}{'-X importtime ms':>18}"
    print(head)
    print("  " + "-" * (len(head) - 2))
    print(f"  {'(empty interpreter)':<22}{base * 1e3:>10.1f}{'':>18}")
    for m in modules:
        ms = (statistics.median(wall[m]) - base) * 1e3
        xms = statistics.median(xtime[m]) / 1e3
        print(f"  {m:<22}{ms:>10.1f}{xms:>18.1f}")
        if m == "agentic_core.graph":
            report.add(
                f"import agentic_core.graph < {IMPORT_TARGET_MS:.0f} ms",
                f"{ms:.1f} ms wall, {xms:.1f} ms -X importtime",
                ms < IMPORT_TARGET_MS,
            )


def print_targets(report: Report) -> None:
    print()
    print("Targets")
    width = max(len(t.name) for t in report.targets)
    for t in report.targets:
        print(f"  {t.verdict:<5} {t.name:<{width}}  {t.measured}")


def profile_ours(mode: str, steps: int) -> None:
    """Case 1 for our runtime under cProfile in this process: what a superstep spends its time on."""
    with tempfile.TemporaryDirectory(prefix="graph-overhead-") as tmp:
        graph = build_loop_graph("ours", steps).compile(checkpointer=make_saver("ours", mode, Path(tmp), "profiled"))
        profiler = cProfile.Profile()
        profiler.enable()
        graph.invoke({"count": 0}, run_config(2 * steps))
        profiler.disable()
    print(f"cProfile of our runtime, {MODE_LABELS[mode]}, {2 * steps} supersteps (top 25 by own time):")
    pstats.Stats(profiler).sort_stats("tottime").print_stats(25)


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--runs", type=int, default=None, help="fresh processes per measurement (default 5)")
    p.add_argument("--steps", type=int, default=None, help="loop count / appended items (default 1000)")
    p.add_argument("--quick", action="store_true", help="a smoke run: 1 run, 20 steps, 1 import sample")
    p.add_argument("--profile", choices=MODES, default=None, help="cProfile our runtime in case 1 and stop")
    p.add_argument("--child", choices=("superstep", "append"), help=argparse.SUPPRESS)
    p.add_argument("--impl", choices=IMPLS, default="ours", help=argparse.SUPPRESS)
    p.add_argument("--mode", choices=MODES, default="none", help=argparse.SUPPRESS)
    p.add_argument("--method", choices=("tracemalloc", "rss"), default="tracemalloc", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.runs is None:
        args.runs = 1 if args.quick else 5
    if args.steps is None:
        args.steps = 20 if args.quick else 1000
    if args.runs < 1 or args.steps < 1:
        p.error("--runs and --steps must be positive")
    return args


def main(argv: Sequence[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child:
        child_main(args)
        return 0
    if args.profile:
        profile_ours(args.profile, args.steps)
        return 0
    lg_reason = available("langgraph")
    if lg_reason is not None:
        lg_reason = f"langgraph is not importable ({lg_reason})"
    import_samples = 1 if args.quick else max(5, 2 * args.runs)
    print(TABLE_HEADER)
    print(
        f"python {platform.python_version()} on {platform.machine()}, {os.cpu_count()} CPU(s);"
        f" agentic-uavs {version_of('agentic-uavs')}, langgraph {version_of('langgraph')},"
        f" langgraph-checkpoint {version_of('langgraph-checkpoint')},"
        f" langgraph-checkpoint-sqlite {version_of('langgraph-checkpoint-sqlite')}"
    )
    print(f"runs={args.runs} steps={args.steps}{' (quick)' if args.quick else ''}")
    if lg_reason is not None:
        print(f"LangGraph columns skipped: {lg_reason}")
    report = Report()
    sections: list[Callable[[], None]] = [
        lambda: case_superstep(args.runs, args.steps, lg_reason, report),
        lambda: case_append(args.runs, args.steps, lg_reason, report),
        lambda: case_import(import_samples, lg_reason, report),
    ]
    for section in sections:
        section()
        sys.stdout.flush()
    print_targets(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
