"""The memory store at fleet scale (issue 20's targets: 50,000 memories, p95 search under 50 ms; embedding at least
30 sentences/s). Prints a table; ``--quick`` for 5,000 memories.

    python benchmarks/memory.py [--quick] [--n N]

Embedding 50,000 texts with the model would take the better part of half an hour, so the stored memories get
seeded random unit vectors of the model's width (384) through the store's own write path; every query is then
embedded by the real model (when the ``embed`` extra is installed), so the search times include it. The store is a
file in a temporary folder, in WAL mode, as a run's memory is.
"""

from __future__ import annotations

import os

# One BLAS thread, unless told otherwise: on a small shared machine OpenBLAS's threads wait on each other, and a
# one-sentence query then takes ten times as long (set before numpy is imported, which is when OpenBLAS reads it).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agentic_core.memory import PutOp, SqliteStore, near, within_last
from agentic_core.memory.embed import available
from agentic_core.memory.embed.base import FunctionEmbedder, Matrix

HOME = (21.4133, 39.8933)
DOMAIN = [
    "casualty", "heat", "stroke", "crowd", "dense", "gate", "bridge", "ramp", "tent", "shade", "pilgrim", "collapsed",
    "still", "moving", "alert", "medical", "kit", "landing", "battery", "wind", "camp", "road", "flow", "barrier",
    "exit", "water",
]  # fmt: skip
WORDS = DOMAIN + [f"w{i:03d}" for i in range(600)]  # a vocabulary of about 600 words, drawn Zipf-like below
QUERIES = ["someone collapsed in the heat near the ramp", "the crowd is too dense at the gate", "medical team alert",
           "a pilgrim lying still in the sun", "barrier pressure on the bridge"]  # fmt: skip
TARGET_P95_MS = 50.0
TARGET_SENTENCES_S = 30.0


def random_vectors(texts: Sequence[str]) -> Matrix:
    """Seeded unit vectors of the model's width, one per text (the stand-in for embedding 50,000 texts)."""
    rng = np.random.default_rng(len(texts))
    m = rng.standard_normal((len(texts), 384)).astype(np.float32)
    out: Matrix = m / np.linalg.norm(m, axis=1, keepdims=True)
    return out


def fill(store: SqliteStore, n: int, seed: int = 0) -> float:
    """Write ``n`` memories in batches of 1,000; seconds taken."""
    rng = np.random.default_rng(seed)
    start = time.perf_counter()
    for first in range(0, n, 1000):
        ops = []
        for i in range(first, min(n, first + 1000)):
            words = " ".join(WORDS[min(int(k), len(WORDS)) - 1] for k in rng.zipf(1.3, size=12))
            north, east = rng.uniform(-3000, 3000, size=2)
            value: dict[str, Any] = {
                "text": f"memory {i}: {words}",
                "where": {"lat": HOME[0] + north / 111_000, "lon": HOME[1] + east / 103_000},
                "t": time.time() - float(rng.uniform(0, 7 * 86_400)),
            }
            ops.append(PutOp(("memory", "incident" if i % 3 else "decision"), f"R{i // 500}:{i}", value))
        store.batch(ops)
    return time.perf_counter() - start


def timed_ms(fn: Callable[[], Any], rounds: int) -> list[float]:
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        fn()
        times.append((time.perf_counter() - start) * 1000)
    return times


def p95(times: list[float]) -> float:
    return float(np.percentile(times, 95))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="5,000 memories and fewer rounds")
    parser.add_argument("--n", type=int, default=None, help="how many memories (default 50,000)")
    args = parser.parse_args(argv)
    n = args.n or (5_000 if args.quick else 50_000)
    rounds = 40 if args.quick else 200
    model = available()
    with tempfile.TemporaryDirectory() as folder:
        index: dict[str, Any] = {"dims": 384, "fields": ["text"]}
        index["embed"] = "all-MiniLM-L6-v2" if model else random_vectors
        store = SqliteStore(Path(folder) / "memory.db", index=index)
        real = store.embedder
        store.embedder = FunctionEmbedder(random_vectors, "random")
        fill_s = fill(store, n)
        store.embedder = real
        queries = iter(QUERIES * rounds)
        store.search(("memory",), query="warm up")  # loads the vector matrix and the model once
        cases: dict[str, Callable[[], Any]] = {
            "query (hybrid)": lambda: store.search(("memory",), query=next(queries), limit=10),
            "query + within 200 m": lambda: store.search(
                ("memory",), query=next(queries), limit=5, filter={"where": near(*HOME, 200)}
            ),
            "within 500 m, last day (no query)": lambda: store.search(
                ("memory",), limit=10, filter={"where": near(*HOME, 500), "t": within_last(86_400)}
            ),
        }
        if real is not None:
            cases["the query's embedding alone"] = lambda: real.embed([next(queries)])
        rows = [(name, timed_ms(fn, rounds)) for name, fn in cases.items()]
        store.close()
    print(f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}; load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")  # fmt: skip
    print(f"memory store: {n:,} memories written in {fill_s:.1f} s ({n / fill_s:,.0f}/s); "
          f"queries embedded by {'all-MiniLM-L6-v2' if model else 'random vectors (embed extra absent)'}")  # fmt: skip
    print(f"{'search':<36} {'p50 ms':>8} {'p95 ms':>8}   target p95 < {TARGET_P95_MS:.0f} ms")
    for name, times in rows:
        mark = "ok" if p95(times) < TARGET_P95_MS else "OVER"
        print(f"{name:<36} {statistics.median(times):8.1f} {p95(times):8.1f}   {mark}")
    if model:
        from agentic_core.memory.embed.minilm import MiniLM

        sentences = [f"pilgrim {i} {' '.join(DOMAIN[i % 7 : i % 7 + 6])} near gate {i % 5}" for i in range(300)]
        start = time.perf_counter()
        MiniLM.shared().embed(sentences)
        rate = len(sentences) / (time.perf_counter() - start)
        mark = "ok" if rate >= TARGET_SENTENCES_S else "UNDER"
        print(f"embedding: {rate:.0f} sentences/s (300 short sentences, batches of 32)   target >= 30   {mark}")
    else:
        print("embedding: not measured (the embed extra is not installed)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
