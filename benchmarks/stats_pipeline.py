"""Benchmark of the statistics pipeline (``evaluation.stats``): analysis and all three renderings.

Scenarios, each in a fresh subprocess so that its peak memory is its own:

* ``small-csv``   — a DecisionRecord results file, 3 systems × 44 records, five outcomes (the paper's size):
  read, analyse, render Markdown, LaTeX and JSON. Target < 0.3 s.
* ``large-array`` — 3 groups × 1,000,000 processing times in memory: analyse and render. Target < 5 s and
  < 1.5 GB peak RSS.
* ``large-csv``   — the same 3,000,000 values read from a CSV file first (reported, same targets).
* ``many-groups`` — the documented limit, 100 groups × 6 values: every pair of Tukey HSD, Games–Howell, Dunn and
  Mann–Whitney (4,950 each), analysed and rendered. Target < 15 s.

Times are wall-clock medians of warm runs (imports and one warm-up excluded; the cold first run is shown too).

Usage: ``python benchmarks/stats_pipeline.py`` (all scenarios) or ``--scenario NAME``.
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

TARGETS = {
    "small-csv": (0.3, 1536.0),
    "large-array": (5.0, 1536.0),
    "large-csv": (5.0, 1536.0),
    "many-groups": (15.0, 1536.0),
}
SYSTEMS = (("yolo", 29.5e-6, 9.4e-6, 0.0, 0.0), ("gemma", 1.48, 0.58, 0.79, 0.88), ("gpt4", 4.95, 1.15, 0.92, 0.94))


def _small_csv(directory: Path) -> Path:
    rng = np.random.default_rng(2024)
    lines = ["scene_id,system,processing_time_s,detection_confidence,person_detected,n_actions,contextual,error"]
    for system, mean, sd, p_action, p_context in SYSTEMS:
        for i in range(44):
            lines.append(
                f"s{i:03d},{system},{abs(rng.normal(mean, sd))!r},{min(1.0, abs(rng.normal(0.75, 0.12))):.3f},"
                f"{rng.random() < 0.85},{int(rng.random() < p_action) * int(rng.integers(1, 4))},"
                f"{rng.random() < p_context},"
            )
    path = directory / "small.csv"
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _large_groups(n: int = 1_000_000) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(2024)
    return {system: np.abs(rng.normal(mean, sd, n)) for system, mean, sd, _, _ in SYSTEMS}


def _large_csv(directory: Path) -> Path:
    path = directory / "large.csv"
    with path.open("w", encoding="utf-8") as fh:
        fh.write("system,processing_time_s\n")
        for system, values in _large_groups().items():
            fh.write("".join(f"{system},{v!r}\n" for v in values.tolist()))
    return path


def _render(report: object) -> int:
    from evaluation.stats import StatsReport

    assert isinstance(report, StatsReport)
    return len(report.to_markdown()) + len(report.to_latex()) + len(report.to_json())


def run_scenario(name: str, repeats: int) -> dict[str, float | str]:
    from evaluation.stats import Dataset, analyze

    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        if name == "small-csv":
            path = _small_csv(directory)

            def job() -> int:
                return _render(analyze(path))

        elif name == "large-array":
            dataset = Dataset.from_groups(_large_groups(), name="processing_time_s", label="Processing Time")

            def job() -> int:
                return _render(analyze(dataset))

        elif name == "large-csv":
            path = _large_csv(directory)

            def job() -> int:
                return _render(analyze(path))

        elif name == "many-groups":
            rng = np.random.default_rng(7)
            groups = {f"g{i:03d}": rng.normal(i % 7, 1.0 + (i % 3), 6) for i in range(100)}
            many = Dataset.from_groups(groups, name="score", label="Score")

            def job() -> int:
                return _render(analyze(many))

        else:
            raise SystemExit(f"unknown scenario {name!r}")
        start = time.perf_counter()
        job()
        cold = time.perf_counter() - start
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            job()
            times.append(time.perf_counter() - start)
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return {"scenario": name, "cold_s": cold, "median_s": statistics.median(times), "peak_rss_mb": peak_mb}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", choices=sorted(TARGETS))
    parser.add_argument("--repeats", type=int, default=None)
    args = parser.parse_args(argv)
    if args.scenario:
        repeats = args.repeats or {"small-csv": 20, "many-groups": 1}.get(args.scenario, 3)
        print(json.dumps(run_scenario(args.scenario, repeats)))
        return 0
    rows = []
    for name in TARGETS:
        out = subprocess.run(
            [sys.executable, __file__, "--scenario", name], capture_output=True, text=True, check=True
        ).stdout
        rows.append(json.loads(out.strip().splitlines()[-1]))
    columns = ("cold (s)", 9), ("warm median (s)", 16), ("target (s)", 11), ("peak RSS (MB)", 14), ("target (MB)", 12)
    print(f"{'scenario':<12} " + " ".join(f"{name:>{width}}" for name, width in columns) + "  ok")
    failed = False
    for row in rows:
        t_target, m_target = TARGETS[str(row["scenario"])]
        ok = float(row["median_s"]) < t_target and float(row["peak_rss_mb"]) < m_target
        failed |= not ok
        print(
            f"{row['scenario']:<12} {row['cold_s']:>9.3f} {row['median_s']:>16.3f} {t_target:>11.1f} "
            f"{row['peak_rss_mb']:>14.0f} {m_target:>12.0f}  {'yes' if ok else 'NO'}"
        )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
