"""The report's PNG plots: one per continuous outcome and one for the rates, drawn from the report's summaries."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from evaluation.stats import Dataset, StatsReport, analyze
from evaluation.stats.plots import plot_continuous, write_plots

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def decision_records(path: Path) -> Path:
    rng = np.random.default_rng(7)
    rows = ["system,processing_time_s,person_detected,contextual"]
    for system, scale in (("yolo", 0.02), ("rules", 0.2), ("llm", 3.0)):
        for i in range(30):
            rows.append(
                f"{system},{rng.lognormal(np.log(scale), 0.3):.6f},{i % 5 != 0},{system != 'yolo' and i % 4 != 0}"
            )
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_a_campaign_report_plots_time_and_rates(tmp_path: Path) -> None:
    report = analyze(str(decision_records(tmp_path / "results.csv")))
    written = write_plots(report, tmp_path)
    assert [p.name for p in written] == ["stats_processing_time_s.png", "stats_rates.png"]
    for path in written:
        width, height = png_size(path)
        assert width > 200 and height > 200


def test_times_spanning_orders_of_magnitude_go_on_a_log_axis(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.axes import Axes

    scales: list[str] = []
    original = Axes.set_yscale

    def record(self: Axes, value: str, **kw: object) -> None:
        scales.append(value)
        original(self, value, **kw)

    monkeypatch.setattr(Axes, "set_yscale", record)
    report = analyze(Dataset.from_groups({"fast": [0.01, 0.012, 0.011], "slow": [2.0, 2.5, 1.5]}, "latency_s"))
    plot_continuous(report.continuous[0], tmp_path / "t.png")
    assert scales == ["log"]
    scales.clear()
    report = analyze(Dataset.from_groups({"a": [-1.0, 0.5, 1.0], "b": [2.0, 2.5, 1.5]}, "latency_s"))
    plot_continuous(report.continuous[0], tmp_path / "u.png")  # not all positive: linear
    assert scales == []


def test_a_report_read_back_from_json_plots_the_same(tmp_path: Path) -> None:
    report = analyze(str(decision_records(tmp_path / "results.csv")))
    again = StatsReport.model_validate_json(report.to_json())
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    first = [p.read_bytes() for p in write_plots(report, tmp_path / "a")]
    second = [p.read_bytes() for p in write_plots(again, tmp_path / "b")]
    assert first == second


def test_a_group_with_no_values_is_left_out_not_an_error(tmp_path: Path) -> None:
    report = analyze(Dataset.from_groups({"a": [1.0, 2.0, 3.0], "b": [2.0, 3.0, 4.0], "c": [np.nan, np.nan]}, "x"))
    assert png_size(plot_continuous(report.continuous[0], tmp_path / "x.png"))[0] > 100


def test_rates_of_zero_and_one_plot_though_their_bounds_round_inside_them(tmp_path: Path) -> None:
    path = tmp_path / "r.csv"
    rows = ["system,processing_time_s,person_detected"]
    rows += [f"{s},{0.1 + i / 100},{'true' if s == 'a' else 'false'}" for s in ("a", "b") for i in range(10)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    written = write_plots(analyze(str(path)), tmp_path)
    assert [p.name for p in written] == ["stats_processing_time_s.png", "stats_rates.png"]


def test_every_value_is_a_point_and_a_legend_says_what_each_mark_is(tmp_path: Path) -> None:
    from evaluation.stats.dataset import load_dataset
    from evaluation.stats.pipeline import analyze_dataset
    from evaluation.stats.plots import continuous_figure, group_points

    dataset = load_dataset(str(decision_records(tmp_path / "results.csv")))
    report = analyze_dataset(dataset)
    result = report.continuous[0]
    points = group_points(dataset, result.column)
    assert points is not None and sorted(len(v) for v in points.values()) == [30, 30, 30]
    ax = continuous_figure(result, points).axes[0]
    offsets = [np.asarray(c.get_offsets()) for c in ax.collections]
    drawn = sorted(float(y) for o in offsets if o.shape == (30, 2) for y in o[:, 1])
    assert drawn == sorted(v for values in points.values() for v in values)
    legend = ax.get_legend()
    assert legend is not None
    labels = [t.get_text() for t in legend.get_texts()]
    assert labels == ["quartiles (box), range (whiskers)", "median", "mean, 95% CI", "each record"]
    bare = continuous_figure(result).axes[0]  # from stats.json alone: no points, and the legend says no more
    bare_legend = bare.get_legend()
    assert bare_legend is not None and [t.get_text() for t in bare_legend.get_texts()] == labels[:3]
