"""Assumption checks: Shapiro–Wilk normality per group and Levene's test of equal variances."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence

import numpy as np
from scipy import stats as st

from evaluation.stats import pvalues
from evaluation.stats._typing import FloatArray
from evaluation.stats.models import NOT_FINITE, NormalityTest, VarianceTest

#: scipy's Shapiro–Wilk p-value approximation (Royston 1995) is validated up to this sample size.
SHAPIRO_VALIDATED_N = 5000


def shapiro_wilk(group: str, values: FloatArray) -> NormalityTest:
    """Shapiro–Wilk W and p for one group; not computed for n < 3 or constant values."""
    n = int(values.size)
    if n < 3:
        return NormalityTest(group=group, n=n, reason=f"needs at least 3 values (has {n})")
    if float(np.ptp(values)) == 0.0:
        return NormalityTest(group=group, n=n, reason="all values are equal: normality is undefined")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = st.shapiro(values)
    if not (math.isfinite(result.statistic) and math.isfinite(result.pvalue)):
        return NormalityTest(group=group, n=n, reason=NOT_FINITE)
    caveat = None
    if n > SHAPIRO_VALIDATED_N:
        caveat = f"n = {n} > {SHAPIRO_VALIDATED_N}: the p-value approximation is not validated this far"
    return NormalityTest(
        group=group, n=n, statistic=float(result.statistic), p=pvalues.exact(float(result.pvalue)), reason=caveat
    )


def levene(samples: Sequence[FloatArray], center: str = "median") -> VarianceTest:
    """Levene's test; ``center="median"`` (scipy's and pingouin's default) is the Brown–Forsythe variant."""
    name = "Levene (median-centred, Brown–Forsythe)" if center == "median" else f"Levene ({center}-centred)"
    k = len(samples)
    n_total = sum(int(s.size) for s in samples)
    if k < 2:
        return VarianceTest(test=name, reason="needs at least 2 groups")
    if any(s.size == 0 for s in samples):
        return VarianceTest(test=name, reason="a group has no values")
    if n_total <= k:
        return VarianceTest(test=name, reason="needs more observations than groups")
    if all(float(np.ptp(s)) == 0.0 if s.size else True for s in samples):
        return VarianceTest(test=name, reason="every group is constant: variances are all zero")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = st.levene(*samples, center=center)
    statistic = float(result.statistic)
    if not np.isfinite(statistic):
        return VarianceTest(test=name, reason="not defined: no spread around the group centres")
    return VarianceTest(
        test=name,
        statistic=statistic,
        df=(float(k - 1), float(n_total - k)),
        p=pvalues.exact(float(result.pvalue)),
    )


__all__ = ["SHAPIRO_VALIDATED_N", "levene", "shapiro_wilk"]
