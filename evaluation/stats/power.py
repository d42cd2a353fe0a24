"""Post-hoc (observed) power with statsmodels, for the one-way ANOVA and the chi-square test.

Observed power is a one-to-one function of the p-value and adds no evidence beyond it (Hoenig & Heisey,
2001); it is reported because the paper reports it. statsmodels is imported lazily (it is slow to import).
"""

from __future__ import annotations

import math

from evaluation.stats import effect_sizes as es


def anova_power(eta2: float, n_total: int, k: int, alpha: float = 0.05) -> float | None:
    """Power of the one-way ANOVA F test for Cohen's f = sqrt(eta² / (1 - eta²)), N observations, k groups
    (statsmodels ``FTestAnovaPower``: noncentrality f² N)."""
    if k < 2 or n_total <= k:
        return None
    f = es.cohen_f(eta2)
    if f is None:
        return 1.0
    from statsmodels.stats.power import FTestAnovaPower

    return _clip(FTestAnovaPower().power(effect_size=f, nobs=n_total, alpha=alpha, k_groups=k))


def chi2_power(w: float, n_total: int, dof: int, alpha: float = 0.05) -> float | None:
    """Power of a chi-square test with ``dof`` degrees of freedom for Cohen's w and N observations
    (statsmodels ``GofChisquarePower`` with ``n_bins = dof + 1``: noncentrality w² N)."""
    if dof < 1 or n_total <= 0:
        return None
    from statsmodels.stats.power import GofChisquarePower

    return _clip(GofChisquarePower().power(effect_size=w, nobs=n_total, alpha=alpha, n_bins=dof + 1))


def _clip(value: object) -> float | None:
    x = float(value)  # type: ignore[arg-type]
    if not math.isfinite(x):
        return None
    return min(max(x, 0.0), 1.0)


__all__ = ["anova_power", "chi2_power"]
