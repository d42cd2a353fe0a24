"""The paper's Table 2 (performance comparison) and Table 3 (deployment) built from a report, independent of
the output format. Cells are plain text; :mod:`render_markdown` and :mod:`render_latex` lay them out."""

from __future__ import annotations

from dataclasses import dataclass, field

from evaluation.stats import formatting as fmt
from evaluation.stats.models import CategoricalAnalysis, ContinuousAnalysis, OmnibusResult
from evaluation.stats.parametric import WELCH
from evaluation.stats.pvalues import format_p_apa
from evaluation.stats.report import StatsReport

SECTIONS = {
    "processing_time_s": "Computational Performance",
    "detection_confidence": "Detection Performance",
    "person_detected": "Detection Performance",
    "action_recommended": "Decision-Making Capability",
    "contextual": "Decision-Making Capability",
    "correct_severity": "Against the Ground Truth",
    "missed_casualty": "Against the Ground Truth",
    "false_alarm": "Against the Ground Truth",
}
STAT_SYMBOL = {"F": "F", "H": "H", "chi2": "χ²"}


@dataclass
class Row:
    label: str
    cells: list[str]
    stat: str = "--"
    sub_label: str = ""
    sub_cells: list[str] | None = None
    sub_stat: str = ""


@dataclass
class Section:
    title: str


@dataclass
class Table:
    caption: str
    label: str
    header: list[str]
    rows: list[Row | Section]
    notes: list[str] = field(default_factory=list)


def statistic_text(result: OmnibusResult) -> tuple[str, str]:
    """(``F = 514.0``, ``p < 0.001``) or a dash and the reason's start."""
    if result.statistic is None or result.p is None:
        return "n/a", "not computable"
    symbol = STAT_SYMBOL.get(result.statistic_name, result.statistic_name)
    if result.test == WELCH:
        symbol = f"Welch {symbol}"
    return (
        f"{symbol} = {fmt.sig(result.statistic, 4) if result.statistic < 1e4 else fmt.sig(result.statistic, 3)}",
        format_p_apa(result.p),
    )


def is_time(result: ContinuousAnalysis) -> bool:
    name = result.column.lower()
    return result.unit in {"s", "ms", "µs"} or "time" in name or "latency" in name


def time_outcome(report: StatsReport) -> ContinuousAnalysis | None:
    return next((c for c in report.continuous if is_time(c)), None)


def _baseline(report: StatsReport, result: ContinuousAnalysis) -> str | None:
    if report.baseline is not None:
        return report.baseline
    present = [g for g in result.groups if g.mean is not None]
    return min(present, key=lambda g: g.mean or 0.0).group if present else None


def table2(report: StatsReport) -> Table:
    """Rows of the paper's Table 2: sample size, then each outcome with the chosen test's statistic."""
    groups = report.groups
    rows: list[Row | Section] = [Row("Sample Size (n)", [str(report.group_sizes[g]) for g in groups])]
    notes: list[str] = []
    ordered: list[ContinuousAnalysis | CategoricalAnalysis] = [*report.continuous, *report.categorical]
    if report.data_schema == "decision-records":
        order = list(SECTIONS)
        ordered.sort(key=lambda r: order.index(r.column) if r.column in order else len(order))
    current = None
    for result in ordered:
        if report.data_schema == "decision-records":
            title = SECTIONS.get(result.column, "Other Outcomes")
        else:
            title = "Continuous Outcomes" if isinstance(result, ContinuousAnalysis) else "Categorical Outcomes"
        if title != current:
            rows.append(Section(title))
            current = title
        if isinstance(result, ContinuousAnalysis):
            rows.extend(_continuous_rows(report, result, notes))
        else:
            rows.append(_categorical_row(result, notes))
    return Table(
        caption="Performance comparison between groups",
        label="tab:perf_comparison",
        header=groups,
        rows=rows,
        notes=notes,
    )


def _continuous_rows(report: StatsReport, result: ContinuousAnalysis, notes: list[str]) -> list[Row]:
    by_group = {g.group: g for g in result.groups}
    chosen = result.chosen_omnibus()
    stat, p = statistic_text(chosen)
    cells = [fmt.mean_sd(by_group[g].mean, by_group[g].sd, result.unit) for g in report.groups]
    rows = [Row(result.label, cells, stat, "(mean ± SD)", None, p)]
    paper_stat, paper_p = statistic_text(result.anova)
    note = f"{result.label}: {chosen.test} ({'; '.join(result.decision.reasons)})"
    if chosen.test != result.anova.test:
        note += f"; the paper's choice, {result.anova.test}, gives {paper_stat}, {paper_p}"
    notes.append(note + ".")
    if is_time(result):
        base = _baseline(report, result)
        base_mean = by_group[base].mean if base else None
        if base and base_mean:
            speed = []
            sub = []
            for g in report.groups:
                mean = by_group[g].mean
                if g == base:
                    speed.append("1×")
                    sub.append("(baseline)")
                elif mean is None:
                    speed.append("–")
                    sub.append("")
                elif mean >= base_mean:
                    speed.append(fmt.ratio(mean / base_mean))
                    sub.append("slower")
                else:
                    speed.append(fmt.ratio(base_mean / mean))
                    sub.append("faster")
            rows.append(Row(f"Speed vs. {base}", speed, "--", "", sub, ""))
    return rows


def _categorical_row(result: CategoricalAnalysis, notes: list[str]) -> Row:
    cells = []
    for g in result.groups:
        rates = [r for r in result.rates if r.group == g]
        if result.positive_level is not None:
            r = rates[0]
            cells.append("–" if r.rate is None else f"{r.count} ({fmt.percent(r.rate)})")
        else:
            cells.append("; ".join(f"{r.level} {fmt.percent(r.rate, 0)}" for r in rates if r.rate is not None))
    stat, p = statistic_text(result.chi_square)
    v = result.chi_square.effect_sizes.get("cramers_v")
    if v is not None:
        p = f"{p}; V = {v:.2f}"
    if result.chi_square.statistic is None:
        notes.append(f"{result.label}: chi-square not computable ({result.chi_square.reason}).")
    return Row(result.label, cells, stat, "", None, p)


def table3(report: StatsReport) -> Table | None:
    """The deployment table: per group, processing time, relative latency and the action recommendation rate
    (slowest first, as in the paper). ``None`` without a processing-time outcome."""
    time = time_outcome(report)
    if time is None:
        return None
    present = sorted((g for g in time.groups if g.mean is not None), key=lambda g: -(g.mean or 0.0))
    if not present:
        return None
    fastest = min(g.mean or 0.0 for g in present)
    slowest = max(g.mean or 0.0 for g in present)
    arr = next((c for c in report.categorical if c.column == "action_recommended"), None)
    header = ["Processing Time", "vs. Fastest", "Latency Reduction vs. Slowest"]
    if arr is not None:
        header.append("ARR (95% CI)")
    rows: list[Row | Section] = []
    for g in present:
        mean = g.mean or 0.0
        cells = [
            fmt.mean_sd(g.mean, g.sd, time.unit),
            "1× (fastest)" if mean == fastest else (fmt.ratio(mean / fastest) + " slower" if fastest > 0 else "–"),
            "–" if mean == slowest else fmt.percent(1.0 - mean / slowest, 0),
        ]
        if arr is not None:
            r = next(r for r in arr.rates if r.group == g.group)
            cells.append(
                "–"
                if r.rate is None
                else f"{fmt.percent(r.rate, 0)} ({fmt.percent(r.ci_low, 0)}–{fmt.percent(r.ci_high, 0)})"
            )
        rows.append(Row(g.group, cells))
    notes = [
        "The paper's columns 'Infra Overhead' and 'Deployment Advantage' are not measured by this pipeline.",
    ]
    return Table(caption="Deployment comparison", label="tab:llm_opt", header=header, rows=rows, notes=notes)


__all__ = ["Row", "Section", "Table", "is_time", "statistic_text", "table2", "table3", "time_outcome"]
