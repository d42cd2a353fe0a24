"""PNG plots of a statistics report: each continuous outcome by group, and the rates with their intervals.

Drawn from the report's own summaries (quartiles, range, mean and its confidence interval; Wilson intervals for
rates), so a report read back from ``stats.json`` plots the same as a fresh one; given the data set as well, every
value is drawn as a point beside its box. A legend says what each mark is. Times go on a log scale, as the paper's
systems differ by orders of magnitude. matplotlib draws off-screen (no display, no global backend state).

>>> import tempfile
>>> from evaluation.stats import Dataset, analyze
>>> report = analyze(Dataset.from_groups({"fast": [0.1, 0.12, 0.11, 0.13], "slow": [2.0, 2.4, 1.9, 2.2]}, "time_s"))
>>> with tempfile.TemporaryDirectory() as out:
...     [path.name for path in write_plots(report, Path(out))]
['stats_time_s.png']
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from evaluation.stats.dataset import ContinuousColumn, Dataset
from evaluation.stats.models import CategoricalAnalysis, ContinuousAnalysis
from evaluation.stats.report import StatsReport
from evaluation.stats.tables import is_time

_DPI = 120
_BOX = "#9ecae1"
_MEAN = "#08519c"
_POINT = "#d94801"

Points = Mapping[str, Sequence[float]]
"""Each group's values, by group name (missing values left out)."""


def plot_continuous(result: ContinuousAnalysis, path: Path, points: Points | None = None) -> Path:
    """Write :func:`continuous_figure` to ``path`` as PNG."""
    fig = continuous_figure(result, points)
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


def continuous_figure(result: ContinuousAnalysis, points: Points | None = None) -> Figure:
    """One outcome by group: the box spans the quartiles, whiskers the range, the bar is the median, and the dot
    with its error bar is the mean with its 95% confidence interval; ``points`` (each group's values) are drawn
    beside the box, spread sideways by a fixed pattern. Log scale for times when all are positive."""
    groups = [g for g in result.groups if g.n > 0 and g.median is not None]
    fig = Figure(figsize=(1.6 + 1.3 * max(len(groups), 1), 4.0), dpi=_DPI)
    ax = fig.add_subplot()
    drew_points = False
    for x, g in enumerate(groups):
        values = np.asarray((points or {}).get(g.group, ()), dtype=float)
        if values.size:
            spread = 0.3 + 0.1 * np.sin(np.arange(values.size) * 2.399)  # golden-angle pattern: no random state
            ax.scatter(x + spread, values, s=9, color=_POINT, alpha=0.6, linewidths=0, zorder=3)
            drew_points = True
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
    positive = all((g.min if g.min is not None else g.median or 0.0) > 0 for g in groups)
    if is_time(result) and positive and groups:
        ax.set_yscale("log")
    ax.set_ylabel(result.label + (f" ({result.unit})" if result.unit else ""))
    ax.set_title(f"{result.label} by group", fontsize=10)
    ax.grid(axis="y", alpha=0.3, which="both")
    ax.set_xlim(-0.6, len(groups) - 0.4 + (0.3 if drew_points else 0.0))
    ax.legend(handles=_legend(drew_points), fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def _legend(points: bool) -> list[Line2D | Patch]:
    handles: list[Line2D | Patch] = [
        Patch(facecolor=_BOX, edgecolor="0.35", label="quartiles (box), range (whiskers)"),
        Line2D([], [], color="0.1", linewidth=2, label="median"),
        Line2D([], [], color=_MEAN, marker="o", markersize=4, linewidth=1, label="mean, 95% CI"),
    ]
    if points:
        handles.append(Line2D([], [], color=_POINT, marker="o", markersize=3, linewidth=0, label="each record"))
    return handles


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
        handles, _ = ax.get_legend_handles_labels()
        interval = Line2D([], [], color="0.1", marker="_", markersize=8, linewidth=1, label="95% Wilson interval")
        ax.legend(handles=[*handles, interval], fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, format="png", metadata={"Software": None})
    return path


def write_plots(report: StatsReport, out_dir: Path, dataset: Dataset | None = None) -> list[Path]:
    """Write ``stats_<column>.png`` for every continuous outcome and ``stats_rates.png`` when there are binary
    outcomes into ``out_dir``; return the paths written. With ``dataset`` (the one analysed), every value is
    drawn too."""
    written = [
        plot_continuous(result, out_dir / f"stats_{_slug(result.column)}.png", group_points(dataset, result.column))
        for result in report.continuous
    ]
    if any(r.positive_level is not None for r in report.categorical):
        written.append(plot_rates(report.categorical, out_dir / "stats_rates.png"))
    return written


def group_points(dataset: Dataset | None, column: str) -> Points | None:
    """The values of ``column`` by group from ``dataset`` (``None`` without one or without that column)."""
    if dataset is None:
        return None
    try:
        found = dataset.column(column)
    except KeyError:
        return None
    if not isinstance(found, ContinuousColumn):
        return None
    samples, _ = dataset.samples(found)
    return {g: s.tolist() for g, s in zip(dataset.groups, samples, strict=True)}


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "outcome"


__all__ = ["continuous_figure", "group_points", "plot_continuous", "plot_rates", "write_plots"]
