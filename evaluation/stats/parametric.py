"""Parametric tests from group moments (n, mean, variance): one-way ANOVA, Welch's ANOVA, Tukey HSD,
Games–Howell, and Cohen's d / Hedges' g.

Working from moments means the same code runs on raw data and on a paper's published means and SDs.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats as st

from evaluation.stats import effect_sizes as es
from evaluation.stats import pvalues
from evaluation.stats import studentized_range as srange
from evaluation.stats._typing import FloatArray
from evaluation.stats.models import NOT_FINITE, OmnibusResult, PairwiseEffect, PairwiseResult, PosthocResult
from evaluation.stats.power import anova_power

ANOVA = "one-way ANOVA"
WELCH = "Welch's ANOVA"
TUKEY = "Tukey HSD"
GAMES_HOWELL = "Games–Howell"

#: Below this the studentized-range survival function (1 - CDF by numerical integration, as in scipy) is no
#: longer accurate; the p-value is replaced by a rigorous union bound (see :func:`studentized_range_p`).
STUDENTIZED_RANGE_FLOOR = 1e-10


@dataclass(frozen=True)
class Moments:
    """Size, mean and unbiased variance (ddof 1) of one group."""

    label: str
    n: int
    mean: float
    var: float

    @classmethod
    def of(cls, label: str, values: FloatArray) -> Moments:
        n = int(values.size)
        mean = float(np.mean(values)) if n else math.nan
        var = float(np.var(values, ddof=1)) if n >= 2 else math.nan
        if var == 0.0 and float(np.ptp(values)) > 0.0:
            var = math.nan  # underflowed: values far smaller than another group's, on one scale (not constant)
        return cls(label, n, mean, var)

    @classmethod
    def from_sd(cls, label: str, n: int, mean: float, sd: float) -> Moments:
        return cls(label, n, mean, sd * sd)


def studentized_range_p(q: float, k: int, df: float, tail: float | None = None) -> pvalues.PValue:
    """P(Q_{k,df} > q) (``tail``, when already computed). Where the integral falls below its accuracy, report the
    union bound instead: Q > q iff some pair differs by more than q, and each pair's difference over s*sqrt(2) is
    t(df), so P(Q > q) <= C(k, 2) * 2 * P(t_df > q / sqrt(2)) — a true upper bound, and tight in the far tail."""
    p = srange.sf(q, k, df) if tail is None else tail
    if p >= STUDENTIZED_RANGE_FLOOR:
        return pvalues.exact(p)
    n_pairs = k * (k - 1) / 2.0
    log_bound = math.log(2.0 * n_pairs) + float(st.t.logsf(q / math.sqrt(2.0), df))
    if not math.isfinite(log_bound):
        return pvalues.PValue(value=pvalues.FLOAT_FLOOR, bound="upper")
    return pvalues.upper_bound_from_log10(min(log_bound / math.log(10.0), math.log10(STUDENTIZED_RANGE_FLOOR)))


def _check(groups: Sequence[Moments], test: str, statistic_name: str) -> OmnibusResult | None:
    if len(groups) < 2:
        return OmnibusResult(test=test, statistic_name=statistic_name, reason="needs at least 2 groups")
    empty = [g.label for g in groups if g.n == 0]
    if empty:
        return OmnibusResult(test=test, statistic_name=statistic_name, reason=f"no values in group(s) {empty}")
    return None


def one_way_anova(groups: Sequence[Moments], alpha: float = 0.05) -> OmnibusResult:
    """Fisher's one-way ANOVA with eta², omega² and post-hoc power (statsmodels ``FTestAnovaPower``)."""
    problem = _check(groups, ANOVA, "F")
    if problem:
        return problem
    k = len(groups)
    n = np.array([g.n for g in groups], dtype=np.float64)
    means = np.array([g.mean for g in groups])
    variances = np.array([g.var if g.n >= 2 else 0.0 for g in groups])
    n_total = int(n.sum())
    if n_total <= k:
        return OmnibusResult(test=ANOVA, statistic_name="F", reason="needs more observations than groups")
    grand = float((n * means).sum() / n_total)
    ss_between = float((n * (means - grand) ** 2).sum())
    ss_within = float(((n - 1.0) * variances).sum())
    df1, df2 = float(k - 1), float(n_total - k)
    if ss_within == 0.0:
        return OmnibusResult(
            test=ANOVA, statistic_name="F", df=(df1, df2), reason="no within-group variance: every group is constant"
        )
    f_stat = (ss_between / df1) / (ss_within / df2)
    p = pvalues.from_tail(float(st.f.sf(f_stat, df1, df2)), float(st.f.logsf(f_stat, df1, df2)))
    effects: dict[str, float] = {}
    eta2 = es.eta_squared(ss_between, ss_within)
    omega2 = es.omega_squared(ss_between, ss_within, k, n_total)
    if eta2 is not None:
        effects["eta_squared"] = eta2
        f_effect = es.cohen_f(eta2)
        if f_effect is not None:
            effects["cohen_f"] = f_effect
    if omega2 is not None:
        effects["omega_squared"] = omega2
    power = anova_power(eta2, n_total, k, alpha) if eta2 is not None else None
    return OmnibusResult(
        test=ANOVA, statistic_name="F", statistic=f_stat, df=(df1, df2), p=p, effect_sizes=effects, power=power
    )


def welch_anova(groups: Sequence[Moments]) -> OmnibusResult:
    """Welch's heteroscedastic one-way ANOVA (needs n >= 2 and a non-zero variance in every group)."""
    problem = _check(groups, WELCH, "F")
    if problem:
        return problem
    small = [g.label for g in groups if g.n < 2]
    if small:
        return OmnibusResult(test=WELCH, statistic_name="F", reason=f"needs at least 2 values per group: {small}")
    constant = [g.label for g in groups if g.var == 0.0]
    if constant:
        return OmnibusResult(
            test=WELCH, statistic_name="F", reason=f"not defined with a zero-variance group: {constant}"
        )
    k = len(groups)
    n = np.array([g.n for g in groups], dtype=np.float64)
    means = np.array([g.mean for g in groups])
    weights = n / np.array([g.var for g in groups])
    total_weight = float(weights.sum())
    weighted_mean = float((weights * means).sum() / total_weight)
    tmp = float((((1.0 - weights / total_weight) ** 2) / (n - 1.0)).sum())
    a = float((weights * (means - weighted_mean) ** 2).sum()) / (k - 1)
    b = 1.0 + 2.0 * (k - 2) / (k * k - 1.0) * tmp
    f_stat = a / b
    df1 = float(k - 1)
    df2 = (k * k - 1.0) / (3.0 * tmp)
    p = pvalues.from_tail(float(st.f.sf(f_stat, df1, df2)), float(st.f.logsf(f_stat, df1, df2)))
    return OmnibusResult(test=WELCH, statistic_name="F", statistic=f_stat, df=(df1, df2), p=p)


def _pairs(groups: Sequence[Moments]) -> list[tuple[Moments, Moments]]:
    return list(itertools.combinations(groups, 2))


def tukey_hsd(groups: Sequence[Moments], confidence: float = 0.95) -> PosthocResult:
    """Tukey–Kramer HSD: q = |mean_a - mean_b| / sqrt(MSE / 2 (1/n_a + 1/n_b)), p from the studentized
    range with k groups and N - k df; ``p`` is already family-wise. ``statistic`` is q."""
    k = len(groups)
    n_total = sum(g.n for g in groups)
    reason = None
    if k < 2 or any(g.n == 0 for g in groups):
        reason = "needs at least 2 groups with values"
    elif n_total <= k:
        reason = "needs more observations than groups"
    mse = math.nan
    if reason is None:
        mse = sum((g.n - 1) * g.var for g in groups if g.n >= 2) / (n_total - k)
        if mse == 0.0:
            reason = "no within-group variance: every group is constant"
        elif not math.isfinite(mse) or not all(math.isfinite(g.mean) for g in groups):
            reason = NOT_FINITE
    if reason is not None:
        return PosthocResult(test=TUKEY, adjustment="studentized range", comparisons=[], reason=reason)
    df = float(n_total - k)
    q_crit = srange.ppf(confidence, k, df)
    pairs = _pairs(groups)
    ses = [math.sqrt(mse / 2.0 * (1.0 / a.n + 1.0 / b.n)) for a, b in pairs]
    qs = np.array([abs(a.mean - b.mean) / se for (a, b), se in zip(pairs, ses, strict=True)])
    tails = srange.sf_many(qs, k, np.full(qs.shape, df))
    comparisons = []
    for (a, b), se, q, tail in zip(pairs, ses, qs.tolist(), tails.tolist(), strict=True):
        diff = a.mean - b.mean
        p = studentized_range_p(q, k, df, tail)
        comparisons.append(
            PairwiseResult(
                a=a.label,
                b=b.label,
                estimate_name="mean difference",
                estimate=diff,
                statistic_name="q",
                statistic=q,
                df=df,
                ci_low=diff - q_crit * se,
                ci_high=diff + q_crit * se,
                p=p,
                p_adjusted=p,
                extra={"se": se * math.sqrt(2.0)},
            )
        )
    return PosthocResult(test=TUKEY, adjustment="studentized range (family-wise)", comparisons=comparisons)


def games_howell(groups: Sequence[Moments], confidence: float = 0.95) -> PosthocResult:
    """Games–Howell: Welch's t per pair with Welch–Satterthwaite df, p from the studentized range at
    sqrt(2)|t|. ``statistic`` is t (a minus b)."""
    k = len(groups)
    if k < 2:
        return PosthocResult(test=GAMES_HOWELL, adjustment="studentized range", comparisons=[], reason="< 2 groups")
    comparisons: list[PairwiseResult] = []
    pending: list[tuple[int, float, float, float]] = []  # (index, t, df, se) of the pairs still to finish
    for a, b in _pairs(groups):
        if a.n < 2 or b.n < 2:
            comparisons.append(
                PairwiseResult(
                    a=a.label,
                    b=b.label,
                    estimate_name="mean difference",
                    statistic_name="t",
                    reason="needs at least 2 values in each group",
                )
            )
            continue
        va, vb = a.var / a.n, b.var / b.n
        diff = a.mean - b.mean
        if va + vb == 0.0:
            comparisons.append(
                PairwiseResult(
                    a=a.label,
                    b=b.label,
                    estimate_name="mean difference",
                    estimate=diff,
                    statistic_name="t",
                    reason="both groups are constant: the standard error is zero",
                )
            )
            continue
        se = math.sqrt(va + vb)
        if not (math.isfinite(se) and math.isfinite(diff)):
            comparisons.append(
                PairwiseResult(
                    a=a.label, b=b.label, estimate_name="mean difference", statistic_name="t", reason=NOT_FINITE
                )
            )
            continue
        t = diff / se
        df = (va + vb) ** 2 / (va**2 / (a.n - 1) + vb**2 / (b.n - 1))
        pending.append((len(comparisons), t, df, se))
        comparisons.append(
            PairwiseResult(
                a=a.label,
                b=b.label,
                estimate_name="mean difference",
                estimate=diff,
                statistic_name="t",
                statistic=t,
                df=df,
                extra={"se": se},
            )
        )
    if pending:
        dfs = np.array([d for _, _, d, _ in pending])
        qs = np.array([math.sqrt(2.0) * abs(t) for _, t, _, _ in pending])
        q_crits = srange.ppf_many(confidence, k, dfs).tolist()
        tails = srange.sf_many(qs, k, dfs).tolist()
        for (index, _, df, se), q, q_crit, tail in zip(pending, qs.tolist(), q_crits, tails, strict=True):
            c = comparisons[index]
            p = studentized_range_p(q, k, df, tail)
            half = q_crit / math.sqrt(2.0) * se
            diff = c.estimate if c.estimate is not None else math.nan
            update = {"ci_low": diff - half, "ci_high": diff + half, "p": p, "p_adjusted": p}
            comparisons[index] = c.model_copy(update=update)
    return PosthocResult(test=GAMES_HOWELL, adjustment="studentized range (family-wise)", comparisons=comparisons)


def pairwise_effects(groups: Sequence[Moments]) -> list[PairwiseEffect]:
    """Cohen's d (pooled SD) and Hedges' g for every pair (a minus b)."""
    out = []
    for a, b in _pairs(groups):
        if a.n == 0 or b.n == 0 or a.n + b.n < 3:
            out.append(PairwiseEffect(a=a.label, b=b.label, reason="needs at least 3 values over the two groups"))
            continue
        var_a = a.var if a.n >= 2 else 0.0
        var_b = b.var if b.n >= 2 else 0.0
        d = es.cohen_d(a.mean, var_a, a.n, b.mean, var_b, b.n)
        if d is None:
            out.append(PairwiseEffect(a=a.label, b=b.label, reason="pooled SD is zero: d is not defined"))
            continue
        out.append(PairwiseEffect(a=a.label, b=b.label, cohen_d=d, hedges_g=es.hedges_g(d, a.n, b.n)))
    return out


__all__ = [
    "ANOVA",
    "GAMES_HOWELL",
    "STUDENTIZED_RANGE_FLOOR",
    "TUKEY",
    "WELCH",
    "Moments",
    "games_howell",
    "one_way_anova",
    "pairwise_effects",
    "studentized_range_p",
    "tukey_hsd",
    "welch_anova",
]
