"""The whole analysis of a data set: every test on every outcome, and the rule's choice."""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from importlib import metadata

import numpy as np

from evaluation.stats import assumptions, categorical, descriptive, nonparametric, parametric, scaling, selection
from evaluation.stats._typing import FloatArray
from evaluation.stats.dataset import CategoricalColumn, ContinuousColumn, Dataset, load_dataset
from evaluation.stats.models import (
    CategoricalAnalysis,
    ContinuousAnalysis,
    GroupSummary,
    NormalityTest,
    RateSummary,
)
from evaluation.stats.report import StatsReport


def analyze(
    source: str | os.PathLike[str] | Iterable[object] | Dataset,
    group: str | None = None,
    values: Sequence[str] | None = None,
    *,
    categorical: Sequence[str] = (),
    alpha: float = 0.05,
    baseline: str | None = None,
) -> StatsReport:
    """Analyse a results file (CSV/TSV/JSON/JSONL), an iterable of records, or a :class:`Dataset`.

    ``group`` names the group column and ``values`` the outcome columns (both detected when omitted);
    ``categorical`` forces numeric columns to be treated as categories. Bad input raises
    :class:`~evaluation.stats.errors.InputError`.
    """
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    dataset = load_dataset(source, group, values, categorical)
    return analyze_dataset(dataset, alpha=alpha, baseline=baseline)


def analyze_dataset(dataset: Dataset, *, alpha: float = 0.05, baseline: str | None = None) -> StatsReport:
    if baseline is not None and baseline not in dataset.groups:
        from evaluation.stats.errors import InputError

        raise InputError(
            f"baseline {baseline!r} is not a group; the groups are: {', '.join(dataset.groups)}",
            source=dataset.source,
            column=dataset.group_column,
        )
    continuous: list[ContinuousAnalysis] = []
    categorical_results: list[CategoricalAnalysis] = []
    for column in dataset.columns:
        if isinstance(column, ContinuousColumn):
            samples, missing = dataset.samples(column)
            continuous.append(analyze_continuous(column, dataset.groups, samples, missing, alpha))
        else:
            categorical_results.append(analyze_categorical(column, dataset, alpha))
    sizes = np.bincount(dataset.group_codes, minlength=len(dataset.groups))
    return StatsReport(
        source=dataset.source,
        data_schema=dataset.schema,
        group_column=dataset.group_column,
        groups=list(dataset.groups),
        group_sizes={g: int(n) for g, n in zip(dataset.groups, sizes, strict=True)},
        n_records=dataset.n_rows,
        alpha=alpha,
        baseline=baseline,
        rule=selection.RULE_TEXT,
        paper_methods=f"{selection.PAPER_CONTINUOUS}; {selection.PAPER_CATEGORICAL}",
        continuous=continuous,
        categorical=categorical_results,
        skipped=list(dataset.skipped),
        notes=list(dataset.notes),
        software=_versions(),
    )


def analyze_continuous(
    column: ContinuousColumn,
    groups: Sequence[str],
    samples: Sequence[FloatArray],
    missing: Sequence[int],
    alpha: float = 0.05,
) -> ContinuousAnalysis:
    """Descriptives, assumption checks, all omnibus and post-hoc tests, effect sizes and the rule's choice.
    Groups without any value are described but left out of the tests; values too large or small for double
    arithmetic are analysed scaled by a power of two (:mod:`evaluation.stats.scaling`)."""
    summaries = []
    normality = []
    for g, s, m in zip(groups, samples, missing, strict=True):
        own, own_e = scaling.own_scale(s)
        summaries.append(scaling.summary_in_unit(descriptive.summarize(g, own, m), own_e))
        if s.size:
            normality.append(assumptions.shapiro_wilk(g, own))
    e = scaling.exponent(samples)
    if e:
        samples = scaling.scaled(samples, e)
    analysis = _analyze_continuous(column, groups, samples, missing, alpha, summaries, normality)
    return scaling.in_unit(analysis, e)


def _analyze_continuous(
    column: ContinuousColumn,
    groups: Sequence[str],
    samples: Sequence[FloatArray],
    missing: Sequence[int],
    alpha: float,
    summaries: list[GroupSummary],
    normality: list[NormalityTest],
) -> ContinuousAnalysis:
    notes: list[str] = []
    present = [(g, s) for g, s in zip(groups, samples, strict=True) if s.size > 0]
    absent = [g for g, s in zip(groups, samples, strict=True) if s.size == 0]
    if absent:
        notes.append(f"group(s) {absent} have no value for {column.name} and are left out of the tests")
    if sum(missing):
        notes.append(f"{sum(missing)} missing value(s) dropped")
    labels = [g for g, _ in present]
    data = [s for _, s in present]
    moments = [parametric.Moments.of(g, s) for g, s in present]
    homogeneity = assumptions.levene(data)
    kruskal, dunn = nonparametric.kruskal_dunn(labels, data)
    decision = selection.choose_continuous(normality, homogeneity, alpha)
    constant = [g for g, s in present if s.size >= 2 and float(np.ptp(s)) == 0.0]
    if constant:
        notes.append(f"group(s) {constant} are constant (zero variance)")
    return ContinuousAnalysis(
        column=column.name,
        label=column.label,
        unit=column.unit,
        groups=summaries,
        normality=normality,
        homogeneity=homogeneity,
        anova=parametric.one_way_anova(moments, alpha),
        welch_anova=parametric.welch_anova(moments),
        kruskal=kruskal,
        tukey=parametric.tukey_hsd(moments),
        games_howell=parametric.games_howell(moments),
        dunn=dunn,
        mann_whitney=nonparametric.pairwise_mann_whitney(labels, data),
        effect_sizes=parametric.pairwise_effects(moments),
        decision=decision,
        notes=notes,
    )


def analyze_categorical(column: CategoricalColumn, dataset: Dataset, alpha: float = 0.05) -> CategoricalAnalysis:
    groups = list(dataset.groups)
    table = categorical.contingency_table(dataset.group_codes, column.codes, len(groups), len(column.levels))
    omnibus, expected_min, below_5, notes = categorical.chi_square_test(table, groups, column.levels, alpha)
    pairwise = categorical.pairwise_chi_square(table, groups, column.levels, column.positive)
    missing = np.bincount(dataset.group_codes[column.codes < 0], minlength=len(groups))
    rates: list[RateSummary] = []
    shown = [column.positive] if column.positive is not None else range(len(column.levels))
    for g, label in enumerate(groups):
        n = int(table[g].sum())
        for level in shown:
            rates.append(descriptive.rate(label, column.levels[level], int(table[g, level]), n, int(missing[g])))
    if int(missing.sum()):
        notes = [*notes, f"{int(missing.sum())} missing value(s) dropped"]
    return CategoricalAnalysis(
        column=column.name,
        label=column.label,
        kind=column.kind,
        levels=list(column.levels),
        positive_level=column.levels[column.positive] if column.positive is not None else None,
        groups=groups,
        table=table.tolist(),
        rates=rates,
        chi_square=omnibus,
        expected_min=expected_min,
        expected_below_5=below_5,
        pairwise=pairwise,
        decision=selection.choose_categorical(),
        notes=notes,
    )


def _versions() -> dict[str, str]:
    out = {}
    for package in ("numpy", "scipy", "statsmodels", "pydantic"):
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:  # pragma: no cover
            out[package] = "unknown"
    return out


__all__ = ["analyze", "analyze_categorical", "analyze_continuous", "analyze_dataset"]
