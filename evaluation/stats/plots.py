"""PNG plots of a statistics report: each continuous outcome by group, and the rates with their intervals.

Drawn from the report's own summaries (quartiles, range, mean and its confidence interval; Wilson intervals for
rates), so a report read back from ``stats.json`` plots the same as a fresh one. Times go on a log scale, as the
paper's systems differ by orders of magnitude. matplotlib draws off-screen (no display, no global backend state).

>>> import tempfile
>>> from evaluation.stats import Dataset, analyze
>>> report = analyze(Dataset.from_groups({"fast": [0.1, 0.12, 0.11, 0.13], "slow": [2.0, 2.4, 1.9, 2.2]}, "time_s"))
>>> with tempfile.TemporaryDirectory() as out:
...     [path.name for path in write_plots(report, Path(out))]
['stats_time_s.png']
"""

from __future__ import annotations

import re
from pathlib import Path

from matplotlib.figure import Figure

from evaluation.stats.models import CategoricalAnalysis, ContinuousAnalysis
from evaluation.stats.report import StatsReport
from evaluation.stats.tables import is_time

_DPI = 120
_BOX = "#9ecae1"
_MEAN = "#08519c"


def plot_continuous(result: ContinuousAnalysis, path: Path) -> Path:
    """One outcome by group: the box spans the quartiles, whiskers the range, the bar is the median, and the dot
    with its error bar is the mean with its 95% confidence interval. Log scale for times when all are positive."""
    groups = [g for g in result.groups if g.n > 0 and g.median is not None]
    fig = Figure(figsize=(1.6 + 1.3 * max(len(groups), 1), 4.0), dpi=_DPI)
    ax = fig.add_subplot()
    for x, g in enumerate(groups):
        median = g.median if g.median is not None else 0.0  # never None here: filtered above
        low, high = g.min if g.min is not None else median, g.max if g.max is not None else median
        ax.vlines(x, low, high, color="0.35", linewidth=1)
        if g.q1 is not None and g.q3 is not None:
            ax.bar(x, g.q3 - g.q1, bottom=g.q1, width=0.5, color=_BOX, edgecolor="0.35", linewidth=1)
        ax.hlines(median, x - 0.25, x + 0.25, color="0.1", linewidth=2)
        if g.mean is not None:
            lower = max(0.0, g.mean - g.mean_ci_low) if g.mean_ci_low is not None else 0.0
            upper = max(0.0, g.mean_ci_high - g.mean) if g.mean_ci_high is not None else 0.0
            ax.errorbar(x, g.mean, yerr=[[lower], [upper]], fmt="o", color=_MEAN, capsize=4, markersize=4)
    ax.set_xticks(range(len(groups)), [f"{g.group}\n(n={g.n})" for g in groups])
    ax.set_xlim(-0.6, len(groups) - 0.4)
    positive = all((g.min if g.min is not None else g.median or 0.0) > 0 for g in groups)
    if is_time(result) and positive and groups:
        ax.set_yscale("log")
    ax.set_ylabel(result.label + (f" ({result.unit})" if result.unit else ""))
    ax.set_title(f"{result.label} by group", fontsize=10)
    ax.grid(axis="y", alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


def plot_rates(results: list[CategoricalAnalysis], path: Path) -> Path:
    """The rate of each binary outcome (its positive level) by group, as bars with Wilson 95% intervals."""
    binary = [r for r in results if r.positive_level is not None]
    groups = list(dict.fromkeys(g for r in binary for g in r.groups))
    width = 0.8 / max(len(groups), 1)
    fig = Figure(figsize=(2.0 + 1.6 * max(len(binary), 1), 4.0), dpi=_DPI)
    ax = fig.add_subplot()
    for i, group in enumerate(groups):
        xs, heights, lower, upper = [], [], [], []
        for x, result in enumerate(binary):
            rate = next((s for s in result.rates if s.group == group and s.level == result.positive_level), None)
            if rate is None or rate.rate is None:
                continue
            xs.append(x - 0.4 + width * (i + 0.5))
            heights.append(100.0 * rate.rate)
            # clamped: an interval bound can sit a rounding error inside a rate of 0 or 1
            lower.append(max(0.0, 100.0 * (rate.rate - rate.ci_low)) if rate.ci_low is not None else 0.0)
            upper.append(max(0.0, 100.0 * (rate.ci_high - rate.rate)) if rate.ci_high is not None else 0.0)
        ax.bar(xs, heights, width=width * 0.95, label=group, yerr=[lower, upper], capsize=3)
    ax.set_xticks(range(len(binary)), [r.label for r in binary])
    ax.set_ylim(0, 105)
    ax.set_ylabel("rate (%)")
    ax.set_title("Rates by group (95% Wilson intervals)", fontsize=10)
    if groups:
        ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


def write_plots(report: StatsReport, out_dir: Path) -> list[Path]:
    """Write ``stats_<column>.png`` for every continuous outcome and ``stats_rates.png`` when there are binary
    outcomes into ``out_dir``; return the paths written."""
    written = [plot_continuous(result, out_dir / f"stats_{_slug(result.column)}.png") for result in report.continuous]
    if any(r.positive_level is not None for r in report.categorical):
        written.append(plot_rates(report.categorical, out_dir / "stats_rates.png"))
    return written


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "outcome"


__all__ = ["plot_continuous", "plot_rates", "write_plots"]
