"""Markdown: the Table 2 and Table 3 layouts, then every test of every outcome."""

from __future__ import annotations

from collections.abc import Sequence

from evaluation.stats import formatting as fmt
from evaluation.stats.models import (
    CategoricalAnalysis,
    ContinuousAnalysis,
    OmnibusResult,
    PosthocResult,
)
from evaluation.stats.pvalues import PValue, format_p
from evaluation.stats.report import StatsReport
from evaluation.stats.tables import Row, Section, Table, table2, table3


def _escape(text: str) -> str:
    return text.replace("|", "\\|")


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(_escape(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines.extend("| " + " | ".join(_escape(c) for c in row) + " |" for row in rows)
    return "\n".join(lines)


def render_table(table: Table, first: str, last: str | None = "Test Stat. / p") -> str:
    header = [first, *table.header] + ([last] if last else [])
    body: list[list[str]] = []
    for row in table.rows:
        if isinstance(row, Section):
            body.append([f"*{row.title}*"] + [""] * (len(header) - 1))
            continue
        assert isinstance(row, Row)
        cells = list(row.cells)
        if row.sub_cells:
            cells = [f"{c} {s}".strip() for c, s in zip(cells, row.sub_cells, strict=True)]
        label = f"{row.label} {row.sub_label}".strip()
        stat = "; ".join(x for x in (row.stat, row.sub_stat) if x)
        body.append([label, *cells] + ([stat or "--"] if last else []))
    out = [f"**{table.caption}**", "", markdown_table(header, body)]
    if table.notes:
        out.append("")
        out.extend(f"- {note}" for note in table.notes)
    return "\n".join(out)


def _p(p: PValue | None) -> str:
    return "–" if p is None else format_p(p)


def _omnibus_rows(tests: Sequence[OmnibusResult], chosen: str, paper: str) -> list[list[str]]:
    rows = []
    for t in tests:
        marks = " ".join(m for m, on in (("**chosen**", t.test == chosen), ("(paper)", t.test == paper)) if on)
        effects = ", ".join(f"{fmt.effect_name(k)} = {fmt.sig(v, 3)}" for k, v in t.effect_sizes.items())
        rows.append(
            [
                f"{t.test} {marks}".strip(),
                fmt.sig(t.statistic, 4) if t.statistic is not None else f"not computable: {t.reason}",
                fmt.df_text(t.df),
                _p(t.p),
                effects or "–",
                fmt.sig(t.power, 3) if t.power is not None else "–",
            ]
        )
    return rows


def _posthoc(family: PosthocResult, chosen: bool) -> str:
    title = f"**{family.test}**{' (chosen)' if chosen else ''} — adjustment: {family.adjustment}"
    if family.reason and not family.comparisons:
        return f"{title}: not computable ({family.reason})"
    rows = []
    for c in family.comparisons:
        ci = "–" if c.ci_low is None or c.ci_high is None else f"[{fmt.sig(c.ci_low, 3)}, {fmt.sig(c.ci_high, 3)}]"
        effect = "–" if c.effect is None else f"{c.effect_name} = {fmt.sig(c.effect, 3)}"
        extra = ", ".join(f"{k} = {fmt.sig(v, 3)}" for k, v in c.extra.items() if k not in {"exact", "se"})
        rows.append(
            [
                f"{c.a} vs {c.b}",
                fmt.sig(c.estimate, 4),
                fmt.sig(c.statistic, 4) if c.statistic is not None else "–",
                fmt.sig(c.df, 4) if c.df is not None else "–",
                ci,
                _p(c.p),
                _p(c.p_adjusted),
                effect if not extra else f"{effect}; {extra}",
                c.reason or "",
            ]
        )
    header = [
        "pair",
        family.comparisons[0].estimate_name if family.comparisons else "estimate",
        family.comparisons[0].statistic_name if family.comparisons else "statistic",
        "df",
        "95% CI",
        "p",
        "p (adjusted)",
        "effect",
        "note",
    ]
    return f"{title}\n\n{markdown_table(header, rows)}"


def _continuous(result: ContinuousAnalysis, alpha: float) -> str:
    d = result.decision
    unit = f" [{result.unit}]" if result.unit else ""
    parts = [
        f"### {result.label} (`{result.column}`){unit}",
        "",
        f"- Chosen by the rule: **{d.omnibus} + {d.posthoc}**; effect size: {d.effect_size}.",
        *[f"  - {reason}" for reason in d.reasons],
        f"- Paper's choice: {d.paper_choice}. Its rule on these data: {d.paper_rule_outcome}.",
        *[f"- Note: {note}" for note in result.notes],
        "",
        markdown_table(
            ["group", "n", "missing", "mean", "SD", "median", "IQR", "min", "max", "95% CI of mean"],
            [
                [
                    g.group,
                    str(g.n),
                    str(g.n_missing),
                    fmt.sig(g.mean, 4),
                    fmt.sig(g.sd, 4),
                    fmt.sig(g.median, 4),
                    "–" if g.q1 is None else f"{fmt.sig(g.q1, 3)}–{fmt.sig(g.q3, 3)}",
                    fmt.sig(g.min, 4),
                    fmt.sig(g.max, 4),
                    "–" if g.mean_ci_low is None else f"[{fmt.sig(g.mean_ci_low, 4)}, {fmt.sig(g.mean_ci_high, 4)}]",
                ]
                for g in result.groups
            ],
        ),
        "",
        f"**Assumption checks** (α = {alpha:g})",
        "",
        markdown_table(
            ["check", "group", "statistic", "p", "note"],
            [
                [
                    "Shapiro–Wilk",
                    t.group,
                    fmt.sig(t.statistic, 4) if t.statistic is not None else "–",
                    _p(t.p),
                    t.reason or "",
                ]
                for t in result.normality
            ]
            + [
                [
                    result.homogeneity.test,
                    "all",
                    fmt.sig(result.homogeneity.statistic, 4) if result.homogeneity.statistic is not None else "–",
                    _p(result.homogeneity.p),
                    result.homogeneity.reason or f"df = {fmt.df_text(result.homogeneity.df)}",
                ]
            ],
        ),
        "",
        "**Omnibus tests**",
        "",
        markdown_table(
            ["test", "statistic", "df", "p", "effect sizes", "post-hoc power"],
            _omnibus_rows([result.anova, result.welch_anova, result.kruskal], d.omnibus, result.anova.test),
        ),
        "",
    ]
    for family in (result.tukey, result.games_howell, result.dunn, result.mann_whitney):
        parts.extend([_posthoc(family, family.test == d.posthoc), ""])
    parts.extend(
        [
            "**Standardised mean differences** (pooled SD)",
            "",
            markdown_table(
                ["pair", "Cohen's d", "Hedges' g", "note"],
                [
                    [f"{e.a} vs {e.b}", fmt.sig(e.cohen_d, 3), fmt.sig(e.hedges_g, 3), e.reason or ""]
                    for e in result.effect_sizes
                ],
            ),
            "",
        ]
    )
    return "\n".join(parts)


def _categorical(result: CategoricalAnalysis) -> str:
    t = result.chi_square
    parts = [
        f"### {result.label} (`{result.column}`, {result.kind})",
        "",
        f"- Chosen: **{result.decision.omnibus}**, then {result.decision.posthoc}. "
        f"Paper's choice: {result.decision.paper_choice}.",
        "- Counts are used as observed: no continuity correction, no 0.5 added to zero cells.",
        *[f"- Note: {note}" for note in result.notes],
        "",
        markdown_table(
            ["group", *result.levels], [[g, *map(str, row)] for g, row in zip(result.groups, result.table, strict=True)]
        ),
        "",
        markdown_table(
            ["group", "level", "count / n", "rate", "95% CI (Wilson)"],
            [
                [
                    r.group,
                    r.level,
                    f"{r.count} / {r.n}",
                    fmt.percent(r.rate),
                    "–" if r.ci_low is None else f"{fmt.percent(r.ci_low)}–{fmt.percent(r.ci_high)}",
                ]
                for r in result.rates
            ],
        ),
        "",
    ]
    if t.statistic is None:
        parts.append(f"Chi-square: not computable ({t.reason}).")
    else:
        effects = ", ".join(f"{fmt.effect_name(k)} = {fmt.sig(v, 3)}" for k, v in t.effect_sizes.items())
        parts.append(
            f"χ²({fmt.df_text(t.df)}, N = {sum(map(sum, result.table))}) = {fmt.sig(t.statistic, 4)}, "
            f"p = {_p(t.p)}; {effects}; post-hoc power = {fmt.sig(t.power, 3)}; "
            f"smallest expected count {fmt.sig(result.expected_min, 3)}"
        )
    parts.extend(["", _posthoc(result.pairwise, True), ""])
    return "\n".join(parts)


def render_markdown(report: StatsReport) -> str:
    parts = [
        f"# Statistics report: {report.source}",
        "",
        f"Groups (column `{report.group_column}`): "
        + ", ".join(f"{g} (n = {report.group_sizes[g]})" for g in report.groups)
        + f". Records: {report.n_records}. α = {report.alpha:g}.",
        "",
        f"**Test selection rule.** {report.rule}",
        "",
        f"**Paper's methods.** {report.paper_methods}",
        "",
    ]
    if report.skipped:
        parts.extend(["Skipped columns: " + "; ".join(f"`{s.column}` ({s.reason})" for s in report.skipped), ""])
    parts.extend(f"- {note}" for note in report.notes)
    parts.extend(["## Table 2 layout", "", render_table(table2(report), "Metric"), ""])
    t3 = table3(report)
    if t3 is not None:
        parts.extend(["## Table 3 layout", "", render_table(t3, "Configuration", None), ""])
    parts.extend(["## Details", ""])
    parts.extend(_continuous(c, report.alpha) for c in report.continuous)
    parts.extend(_categorical(c) for c in report.categorical)
    parts.append(
        "p-values below the double-precision range (or below the accuracy of the studentized-range "
        "integration) are shown as bounds ('< …'), never as 0."
    )
    return "\n".join(parts).rstrip() + "\n"


__all__ = ["markdown_table", "render_markdown", "render_table"]
