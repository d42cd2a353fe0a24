"""Categorical outcomes: chi-square test of independence (groups × levels) with Cramér's V and power, and the
pairwise 2 × L comparisons with Holm's correction (plus Fisher's exact test for 2 × 2 tables).

Counts are used as observed: no continuity (Yates) correction and no 0.5 added to zero cells. A level that
never occurs (a zero column) carries no information and is dropped; the result notes it.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np
from scipy import stats as st

from evaluation.stats import effect_sizes as es
from evaluation.stats import pvalues
from evaluation.stats._typing import IntArray
from evaluation.stats.models import OmnibusResult, PairwiseResult, PosthocResult
from evaluation.stats.power import chi2_power

CHI_SQUARE = "chi-square test of independence"
PAIRWISE_CHI_SQUARE = "pairwise chi-square (Holm)"


def contingency_table(group_codes: IntArray, level_codes: IntArray, n_groups: int, n_levels: int) -> IntArray:
    """Counts of (group, level) pairs; entries with a missing level (code -1) are skipped."""
    keep = level_codes >= 0
    flat = group_codes[keep] * n_levels + level_codes[keep]
    return np.bincount(flat, minlength=n_groups * n_levels).reshape(n_groups, n_levels).astype(np.int64)


def _chi2(table: IntArray) -> tuple[float, float, float, float]:
    """chi², df, min expected count and the share of expected counts below 5 (no zero margins allowed)."""
    observed = table.astype(np.float64)
    total = observed.sum()
    expected = np.outer(observed.sum(axis=1), observed.sum(axis=0)) / total
    chi2 = float(((observed - expected) ** 2 / expected).sum())
    dof = float((table.shape[0] - 1) * (table.shape[1] - 1))
    return chi2, dof, float(expected.min()), float((expected < 5.0).mean())


def chi_square_test(
    table: IntArray, groups: Sequence[str], levels: Sequence[str], alpha: float = 0.05
) -> tuple[OmnibusResult, float | None, float | None, list[str]]:
    """The omnibus test; returns the result, the minimum expected count, the share of cells with an
    expected count below 5, and notes."""
    notes: list[str] = []
    row_keep = table.sum(axis=1) > 0
    col_keep = table.sum(axis=0) > 0
    dropped_groups = [g for g, keep in zip(groups, row_keep, strict=True) if not keep]
    dropped_levels = [lev for lev, keep in zip(levels, col_keep, strict=True) if not keep]
    if dropped_groups:
        notes.append(f"group(s) {dropped_groups} have no observed value and are left out")
    if dropped_levels:
        notes.append(f"level(s) {dropped_levels} never occur and are left out")
    reduced = table[row_keep][:, col_keep]
    if reduced.shape[0] < 2:
        return (
            OmnibusResult(test=CHI_SQUARE, statistic_name="chi2", reason="needs 2 groups with values"),
            None,
            None,
            notes,
        )
    if reduced.shape[1] < 2:
        level = [lev for lev, keep in zip(levels, col_keep, strict=True) if keep]
        reason = f"the outcome is {level[0]!r} in every group: nothing to test" if level else "no values"
        return OmnibusResult(test=CHI_SQUARE, statistic_name="chi2", reason=reason), None, None, notes
    chi2, dof, expected_min, below_5 = _chi2(reduced)
    n_total = int(reduced.sum())
    p = pvalues.from_tail(float(st.chi2.sf(chi2, dof)), float(st.chi2.logsf(chi2, dof)))
    effects: dict[str, float] = {}
    v = es.cramers_v(chi2, n_total, *reduced.shape)
    w = es.cohens_w(chi2, n_total)
    if v is not None:
        effects["cramers_v"] = v
    if w is not None:
        effects["cohens_w"] = w
    power = chi2_power(w, n_total, int(dof), alpha) if w is not None else None
    if expected_min < 1.0 or below_5 > 0.2:
        notes.append(
            f"expected counts are small (min {expected_min:.2g}, {below_5:.0%} of cells below 5): "
            "the chi-square approximation is doubtful; see Fisher's exact test in the pairwise comparisons"
        )
    result = OmnibusResult(
        test=CHI_SQUARE, statistic_name="chi2", statistic=chi2, df=(dof,), p=p, effect_sizes=effects, power=power
    )
    return result, expected_min, below_5, notes


def pairwise_chi_square(
    table: IntArray, groups: Sequence[str], levels: Sequence[str], positive: int | None = None
) -> PosthocResult:
    """Every pair of groups as a 2 × L table: chi² (no continuity correction), Holm-adjusted; for a binary
    outcome also the rate difference (a minus b) and Fisher's exact p (``extra["fisher_p"]``)."""
    raw: list[PairwiseResult] = []
    for i, j in itertools.combinations(range(len(groups)), 2):
        sub = table[[i, j]]
        n_a, n_b = int(sub[0].sum()), int(sub[1].sum())
        estimate = None
        if positive is not None and n_a and n_b:
            estimate = float(sub[0, positive]) / n_a - float(sub[1, positive]) / n_b
        if n_a == 0 or n_b == 0:
            raw.append(_pair(groups[i], groups[j], reason="a group has no values"))
            continue
        sub = sub[:, sub.sum(axis=0) > 0]
        if sub.shape[1] < 2:
            reason = "the outcome is the same in both groups: nothing to test (left out of the Holm family)"
            raw.append(_pair(groups[i], groups[j], estimate=estimate, reason=reason))
            continue
        chi2, dof, _, _ = _chi2(sub)
        p = pvalues.from_tail(float(st.chi2.sf(chi2, dof)), float(st.chi2.logsf(chi2, dof)))
        extra: dict[str, float] = {}
        if sub.shape[1] == 2:
            extra["fisher_p"] = float(st.fisher_exact(sub).pvalue)
        v = es.cramers_v(chi2, n_a + n_b, *sub.shape)
        raw.append(_pair(groups[i], groups[j], estimate=estimate, statistic=chi2, df=dof, p=p, effect=v, extra=extra))
    adjusted = pvalues.holm([c.p for c in raw])
    comparisons = [c.model_copy(update={"p_adjusted": adj}) for c, adj in zip(raw, adjusted, strict=True)]
    return PosthocResult(test=PAIRWISE_CHI_SQUARE, adjustment="Holm", comparisons=comparisons)


def _pair(
    a: str,
    b: str,
    *,
    estimate: float | None = None,
    statistic: float | None = None,
    df: float | None = None,
    p: pvalues.PValue | None = None,
    effect: float | None = None,
    extra: dict[str, float] | None = None,
    reason: str | None = None,
) -> PairwiseResult:
    return PairwiseResult(
        a=a,
        b=b,
        estimate_name="rate difference",
        estimate=estimate,
        statistic_name="chi2",
        statistic=statistic,
        df=df,
        p=p,
        effect_name="Cramér's V",
        effect=effect,
        extra=extra or {},
        reason=reason,
    )


__all__ = ["CHI_SQUARE", "PAIRWISE_CHI_SQUARE", "chi_square_test", "contingency_table", "pairwise_chi_square"]
