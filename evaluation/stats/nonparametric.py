"""Rank-based tests: Kruskal–Wallis with Dunn's post-hoc test (Holm), and pairwise Mann–Whitney U with the
rank-biserial correlation.

Ranks come from one stable sort of the pooled data, so both tests scale to millions of values.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from scipy import stats as st

from evaluation.stats import effect_sizes as es
from evaluation.stats import pvalues
from evaluation.stats._typing import FloatArray
from evaluation.stats.models import OmnibusResult, PairwiseResult, PosthocResult

KRUSKAL = "Kruskal–Wallis"
DUNN = "Dunn (Holm)"
MANN_WHITNEY = "Mann–Whitney U"


def _tie_counts(sorted_values: FloatArray) -> FloatArray:
    """Sizes of the runs of equal values in a sorted array."""
    n = sorted_values.size
    if n == 0:
        return np.zeros(0)
    starts = np.flatnonzero(np.r_[True, sorted_values[1:] != sorted_values[:-1]])
    return np.asarray(np.diff(np.r_[starts, n]), dtype=np.float64)


def _tie_term(counts: FloatArray) -> float:
    return float((counts**3 - counts).sum())


def _two_sided_normal_p(z: float) -> pvalues.PValue:
    a = abs(z)
    return pvalues.from_tail(min(2.0 * float(st.norm.sf(a)), 1.0), math.log(2.0) + float(st.norm.logsf(a)))


def kruskal_dunn(labels: Sequence[str], samples: Sequence[FloatArray]) -> tuple[OmnibusResult, PosthocResult]:
    """Kruskal–Wallis H (tie-corrected, as scipy) and Dunn's z tests of mean ranks with the tie-corrected
    variance (N(N+1)/12 - sum(t³ - t) / (12 (N - 1))) (1/n_a + 1/n_b), Holm-adjusted."""
    k = len(samples)
    sizes = np.array([s.size for s in samples], dtype=np.int64)
    n_total = int(sizes.sum())
    reason = None
    if k < 2:
        reason = "needs at least 2 groups"
    elif (sizes == 0).any():
        reason = f"no values in group(s) {[lab for lab, n in zip(labels, sizes, strict=True) if n == 0]}"
    if reason is not None:
        return (
            OmnibusResult(test=KRUSKAL, statistic_name="H", reason=reason),
            PosthocResult(test=DUNN, adjustment="Holm", comparisons=[], reason=reason),
        )
    pooled = np.concatenate(samples)
    codes = np.repeat(np.arange(k), sizes)
    order = np.argsort(pooled, kind="stable")
    sorted_values = pooled[order]
    del pooled
    is_start = np.r_[True, sorted_values[1:] != sorted_values[:-1]]
    starts = np.flatnonzero(is_start)
    counts = np.diff(np.r_[starts, n_total]).astype(np.float64)
    average_rank = starts + (counts + 1.0) / 2.0
    ranks_sorted = average_rank[np.cumsum(is_start) - 1]
    rank_sums = np.bincount(codes[order], weights=ranks_sorted, minlength=k)
    del order, ranks_sorted, sorted_values
    tie_term = _tie_term(counts)
    n = float(n_total)
    correction = 1.0 - tie_term / (n**3 - n)
    df = float(k - 1)
    if correction <= 0.0:
        reason = "all values are equal: ranks carry no information"
        return (
            OmnibusResult(test=KRUSKAL, statistic_name="H", df=(df,), reason=reason),
            PosthocResult(test=DUNN, adjustment="Holm", comparisons=[], reason=reason),
        )
    h = (12.0 / (n * (n + 1.0)) * float((rank_sums**2 / sizes).sum()) - 3.0 * (n + 1.0)) / correction
    p = pvalues.from_tail(float(st.chi2.sf(h, df)), float(st.chi2.logsf(h, df)))
    effects: dict[str, float] = {}
    eta2h = es.eta_squared_h(h, k, n_total)
    eps2 = es.epsilon_squared_h(h, n_total)
    if eta2h is not None:
        effects["eta_squared_h"] = eta2h
    if eps2 is not None:
        effects["epsilon_squared"] = eps2
    omnibus = OmnibusResult(test=KRUSKAL, statistic_name="H", statistic=h, df=(df,), p=p, effect_sizes=effects)

    mean_ranks = rank_sums / sizes
    variance_unit = n * (n + 1.0) / 12.0 - tie_term / (12.0 * (n - 1.0))
    raw: list[PairwiseResult] = []
    for i, j in itertools.combinations(range(k), 2):
        diff = float(mean_ranks[i] - mean_ranks[j])
        sigma = math.sqrt(variance_unit * (1.0 / sizes[i] + 1.0 / sizes[j]))
        z = diff / sigma
        raw.append(
            PairwiseResult(
                a=labels[i],
                b=labels[j],
                estimate_name="mean-rank difference",
                estimate=diff,
                statistic_name="z",
                statistic=z,
                p=_two_sided_normal_p(z),
            )
        )
    adjusted = pvalues.holm([c.p for c in raw])
    comparisons = [c.model_copy(update={"p_adjusted": adj}) for c, adj in zip(raw, adjusted, strict=True)]
    return omnibus, PosthocResult(test=DUNN, adjustment="Holm", comparisons=comparisons)


def mann_whitney(label_a: str, a: FloatArray, label_b: str, b: FloatArray) -> PairwiseResult:
    """Two-sided Mann–Whitney U of a vs b, as scipy ``mannwhitneyu`` with its default method choice: the exact
    distribution when there are no ties and a group has at most 8 values, otherwise the normal approximation
    with tie and continuity corrections. ``statistic`` is U of a; ``estimate`` the difference of the medians
    (a minus b), so the table says how far apart the groups sit beside the test's U; the effect is the rank-biserial
    correlation 2 U_a / (n_a n_b) - 1 (+1 when every value of a exceeds every value of b)."""
    n_a, n_b = int(a.size), int(b.size)
    if n_a == 0 or n_b == 0:
        return _mwu(label_a, label_b, reason="a group has no values")
    a_sorted = np.sort(a)
    b_sorted = np.sort(b)
    left = np.searchsorted(b_sorted, a_sorted, side="left")
    right = np.searchsorted(b_sorted, a_sorted, side="right")
    u_a = float(left.sum()) + 0.5 * float((right - left).sum())
    del left, right
    pooled = np.concatenate([a_sorted, b_sorted])
    pooled.sort(kind="stable")
    counts = _tie_counts(pooled)
    del pooled
    ties = bool((counts > 1).any())
    effect = es.rank_biserial(u_a, n_a, n_b)
    shift = float(np.median(a) - np.median(b))
    if (n_a > 8 and n_b > 8) or ties:
        n = float(n_a + n_b)
        s = math.sqrt(n_a * n_b / 12.0 * ((n + 1.0) - _tie_term(counts) / (n * (n - 1.0))))
        if s == 0.0:
            return _mwu(label_a, label_b, u_a, effect, shift, reason="all values in the two groups are equal")
        u_max = max(u_a, n_a * n_b - u_a)
        z = (u_max - n_a * n_b / 2.0 - 0.5) / s
        p = pvalues.from_tail(min(2.0 * float(st.norm.sf(z)), 1.0), math.log(2.0) + float(st.norm.logsf(z)))
        return _mwu(label_a, label_b, u_a, effect, shift, p=p, extra={"z": z, "exact": 0.0})
    result = st.mannwhitneyu(a, b, alternative="two-sided", method="exact")
    return _mwu(label_a, label_b, u_a, effect, shift, p=pvalues.exact(float(result.pvalue)), extra={"exact": 1.0})


def _mwu(
    label_a: str,
    label_b: str,
    u_a: float | None = None,
    effect: float | None = None,
    shift: float | None = None,
    *,
    p: pvalues.PValue | None = None,
    extra: dict[str, float] | None = None,
    reason: str | None = None,
) -> PairwiseResult:
    return PairwiseResult(
        a=label_a,
        b=label_b,
        estimate_name="median difference",
        estimate=shift,
        statistic_name="U",
        statistic=u_a,
        p=p,
        effect_name="rank-biserial r",
        effect=effect,
        extra=extra or {},
        reason=reason,
    )


def pairwise_mann_whitney(labels: Sequence[str], samples: Sequence[FloatArray]) -> PosthocResult:
    """Mann–Whitney U for every pair of groups, with Holm-adjusted p-values."""
    raw = [
        mann_whitney(labels[i], samples[i], labels[j], samples[j])
        for i, j in itertools.combinations(range(len(samples)), 2)
    ]
    adjusted = pvalues.holm([c.p for c in raw])
    comparisons = [c.model_copy(update={"p_adjusted": adj}) for c, adj in zip(raw, adjusted, strict=True)]
    return PosthocResult(test=MANN_WHITNEY, adjustment="Holm", comparisons=comparisons)


__all__ = ["DUNN", "KRUSKAL", "MANN_WHITNEY", "kruskal_dunn", "mann_whitney", "pairwise_mann_whitney"]
