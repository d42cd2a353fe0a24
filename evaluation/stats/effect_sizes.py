"""Effect sizes: Cohen's d, Hedges' g, eta squared, Cohen's f, rank-biserial r, Cramér's V, Cohen's w.

Every function takes summary figures, so the same code serves raw data and the paper's published summaries.
``None`` means "not defined for these figures" (for instance a zero pooled SD).
"""

from __future__ import annotations

import math


def pooled_sd(n_a: int, var_a: float, n_b: int, var_b: float) -> float | None:
    """sqrt(((n_a - 1) var_a + (n_b - 1) var_b) / (n_a + n_b - 2)); ``None`` when the df are zero."""
    dof = n_a + n_b - 2
    if dof <= 0:
        return None
    return math.sqrt(((n_a - 1) * var_a + (n_b - 1) * var_b) / dof)


def cohen_d(mean_a: float, var_a: float, n_a: int, mean_b: float, var_b: float, n_b: int) -> float | None:
    """Cohen's d of a minus b with the pooled SD (as pingouin ``compute_effsize(eftype="cohen")``)."""
    sd = pooled_sd(n_a, var_a, n_b, var_b)
    if sd is None or sd == 0.0:
        return None
    return (mean_a - mean_b) / sd


def hedges_g(d: float | None, n_a: int, n_b: int) -> float | None:
    """Hedges' g = d (1 - 3 / (4 (n_a + n_b) - 9)), the usual approximation to the exact J factor."""
    if d is None or n_a + n_b < 3:
        return None
    return d * (1.0 - 3.0 / (4.0 * (n_a + n_b) - 9.0))


def eta_squared(ss_between: float, ss_within: float) -> float | None:
    """SS_between / SS_total."""
    total = ss_between + ss_within
    if total <= 0.0:
        return None
    return ss_between / total


def omega_squared(ss_between: float, ss_within: float, k: int, n_total: int) -> float | None:
    """(SS_b - (k - 1) MS_w) / (SS_t + MS_w), the less biased companion of eta squared."""
    if n_total <= k:
        return None
    ms_within = ss_within / (n_total - k)
    denominator = ss_between + ss_within + ms_within
    if denominator <= 0.0:
        return None
    return (ss_between - (k - 1) * ms_within) / denominator


def cohen_f(eta2: float) -> float | None:
    """Cohen's f = sqrt(eta² / (1 - eta²)); ``None`` when eta² is 1 (no residual variance)."""
    if eta2 >= 1.0:
        return None
    return math.sqrt(max(eta2, 0.0) / (1.0 - eta2))


def eta_squared_from_f(f_stat: float, df1: float, df2: float) -> float:
    """eta² recovered from an F statistic: F df1 / (F df1 + df2)."""
    return f_stat * df1 / (f_stat * df1 + df2)


def rank_biserial(u_a: float, n_a: int, n_b: int) -> float:
    """Rank-biserial correlation 2 U_a / (n_a n_b) - 1: +1 when every a exceeds every b."""
    return 2.0 * u_a / (n_a * n_b) - 1.0


def epsilon_squared_h(h: float, n_total: int) -> float | None:
    """eta²_H = (H - k + 1) / (N - k) is in :func:`eta_squared_h`; this is epsilon² = H / (N - 1)."""
    if n_total <= 1:
        return None
    return h / (n_total - 1)


def eta_squared_h(h: float, k: int, n_total: int) -> float | None:
    """eta² based on the Kruskal–Wallis H: (H - k + 1) / (N - k)."""
    if n_total <= k:
        return None
    return (h - k + 1) / (n_total - k)


def cramers_v(chi2: float, n_total: int, n_rows: int, n_cols: int) -> float | None:
    """sqrt(chi² / (N min(r - 1, c - 1))), without bias correction."""
    m = min(n_rows - 1, n_cols - 1)
    if n_total <= 0 or m <= 0:
        return None
    return math.sqrt(chi2 / (n_total * m))


def cohens_w(chi2: float, n_total: int) -> float | None:
    """sqrt(chi² / N), the effect size used for chi-square power."""
    if n_total <= 0:
        return None
    return math.sqrt(chi2 / n_total)


__all__ = [
    "cohen_d",
    "cohen_f",
    "cohens_w",
    "cramers_v",
    "epsilon_squared_h",
    "eta_squared",
    "eta_squared_from_f",
    "eta_squared_h",
    "hedges_g",
    "omega_squared",
    "pooled_sd",
    "rank_biserial",
]
