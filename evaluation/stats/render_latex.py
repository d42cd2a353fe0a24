"""LaTeX (booktabs): Table 2 and Table 3 in the paper's layout, plus one table of every omnibus test."""

from __future__ import annotations

import re

from evaluation.stats import formatting as fmt
from evaluation.stats.pvalues import format_p
from evaluation.stats.report import StatsReport
from evaluation.stats.tables import Row, Section, Table, table2, table3

_SPECIAL = {
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\^{}",
    "\\": r"\textbackslash{}",
}
_SYMBOLS = {
    "±": r"$\pm$",
    "µ": r"$\mu$",
    "×": r"$\times$",
    "χ²": r"$\chi^2$",
    "η²": r"$\eta^2$",
    "≥": r"$\geq$",
    "≤": r"$\leq$",
    "α": r"$\alpha$",
    "–": "--",
    "—": "---",
    "≪": r"$\ll$",
}
_SYMBOL_RE = re.compile("|".join(re.escape(k) for k in sorted(_SYMBOLS, key=len, reverse=True)))


_MATH_SYMBOL = {"χ²": r"\chi^2", "α": r"\alpha", "η²": r"\eta^2", "≥": r"\geq", "≤": r"\leq"}
_ASSIGNMENT = re.compile(r"(?<![A-Za-z\\])(χ²|α|η²|F|H|V|p|n)\s*([<=>≥≤])\s*(-?[0-9][0-9.]*(?:e[+-]?[0-9]+)?)")


def _math(match: re.Match[str]) -> str:
    symbol, relation, value = match.groups()
    return f"${_MATH_SYMBOL.get(symbol, symbol)} {_MATH_SYMBOL.get(relation, relation)} {value}$"


def latex_text(text: str) -> str:
    """Escape LaTeX specials, set ``F = 514.0``/``p < 0.001``/``χ² = 82.92`` in math, turn the report's Unicode
    symbols into LaTeX."""
    escaped = "".join(_SPECIAL.get(ch, ch) for ch in text)
    escaped = _ASSIGNMENT.sub(_math, escaped)
    return _SYMBOL_RE.sub(lambda m: _SYMBOLS[m.group(0)], escaped)


def render_table(table: Table, first: str, last: str | None = r"Test Stat. / $p$") -> str:
    n_cols = 1 + len(table.header) + (1 if last else 0)
    spec = "@{}l" + "c" * (n_cols - 1) + "@{}"
    header = [rf"\textbf{{{first}}}", *(rf"\textbf{{{latex_text(h)}}}" for h in table.header)]
    if last:
        header.append(rf"\textbf{{{last}}}")
    lines = [
        r"\begin{table}[htbp]",
        r"\centering",
        rf"\caption{{{latex_text(table.caption)}}}",
        rf"\label{{{table.label}}}",
        r"\footnotesize",
        r"\setlength{\tabcolsep}{4pt}",
        rf"\begin{{tabular}}{{{spec}}}",
        r"\toprule",
        " & ".join(header) + r" \\",
        r"\midrule",
    ]
    for row in table.rows:
        if isinstance(row, Section):
            lines.append(r"\addlinespace[2pt]")
            lines.append(rf"\multicolumn{{{n_cols}}}{{@{{}}l@{{}}}}{{\textit{{{latex_text(row.title)}}}}} \\")
            continue
        assert isinstance(row, Row)
        first_line = [latex_text(row.label), *(latex_text(c) for c in row.cells)]
        if last:
            first_line.append(latex_text(row.stat))
        lines.append(" & ".join(first_line) + r" \\")
        if row.sub_label or row.sub_cells or row.sub_stat:
            sub = [latex_text(row.sub_label), *(latex_text(c) for c in (row.sub_cells or [""] * len(row.cells)))]
            if last:
                sub.append(latex_text(row.sub_stat))
            lines.append(" & ".join(sub) + r" \\")
    lines.extend([r"\bottomrule", r"\end{tabular}"])
    if table.notes:
        lines.append(r"\vspace{2mm}")
        lines.append(r"{\footnotesize " + " ".join(latex_text(n) for n in table.notes) + "}")
    lines.append(r"\end{table}")
    return "\n".join(lines)


def tests_table(report: StatsReport) -> str:
    """Every omnibus test on every outcome, with the rule's choice marked."""
    lines = [
        r"\begin{table}[htbp]",
        r"\centering",
        r"\caption{Omnibus tests (the rule's choice in bold)}",
        r"\label{tab:omnibus_tests}",
        r"\footnotesize",
        r"\begin{tabular}{@{}llcccc@{}}",
        r"\toprule",
        r"\textbf{Outcome} & \textbf{Test} & \textbf{Statistic} & \textbf{df} & \textbf{$p$} & \textbf{Effect} \\",
        r"\midrule",
    ]
    for c in report.continuous:
        for t in (c.anova, c.welch_anova, c.kruskal):
            lines.append(_test_line(c.label, t.test, t.test == c.decision.omnibus, t))
    for k in report.categorical:
        lines.append(_test_line(k.label, k.chi_square.test, True, k.chi_square))
    lines.extend([r"\bottomrule", r"\end{tabular}", r"\end{table}"])
    return "\n".join(lines)


def _test_line(label: str, test: str, chosen: bool, t: object) -> str:
    from evaluation.stats.models import OmnibusResult

    assert isinstance(t, OmnibusResult)
    name = latex_text(test)
    if chosen:
        name = rf"\textbf{{{name}}}"
    if t.statistic is None or t.p is None:
        return (
            rf"{latex_text(label)} & {name} & \multicolumn{{4}}{{l}}{{not computable: {latex_text(t.reason or '')}}} \\"
        )
    effect = ", ".join(
        f"{fmt.effect_name(k)} = {fmt.sig(v, 3)}"
        for k, v in t.effect_sizes.items()
        if k in {"eta_squared", "eta_squared_h", "cramers_v"}
    )
    return (
        f"{latex_text(label)} & {name} & {fmt.sig(t.statistic, 4)} & {fmt.df_text(t.df)} & "
        f"{latex_text(format_p(t.p))} & {latex_text(effect) or '--'} \\\\"
    )


def _with_rule(table: Table, rule: str) -> Table:
    table.notes.append(f"Test selection: {rule}")
    return table


def render_latex(report: StatsReport) -> str:
    parts = [
        f"% Statistics report for {report.source} (agentic-uavs evaluation.stats)",
        "% Requires \\usepackage{booktabs}",
        render_table(_with_rule(table2(report), report.rule), "Metric"),
    ]
    t3 = table3(report)
    if t3 is not None:
        parts.append(render_table(t3, "Configuration", None))
    parts.append(tests_table(report))
    return "\n\n".join(parts) + "\n"


__all__ = ["latex_text", "render_latex", "render_table", "tests_table"]
