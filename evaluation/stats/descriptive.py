"""Per-group descriptive statistics and rates with Wilson score intervals."""

from __future__ import annotations

import math

import numpy as np
from scipy import stats as st

from evaluation.stats._typing import FloatArray
from evaluation.stats.models import GroupSummary, RateSummary


def summarize(group: str, values: FloatArray, n_missing: int = 0, confidence: float = 0.95) -> GroupSummary:
    """Mean, SD (ddof 1), quartiles, range and a t interval for the mean of one group's values."""
    n = int(values.size)
    if n == 0:
        return GroupSummary(group=group, n=0, n_missing=n_missing)
    mean = float(np.mean(values))
    q1, median, q3 = (float(q) for q in np.percentile(values, [25.0, 50.0, 75.0]))
    sd: float | None = None
    ci_low: float | None = None
    ci_high: float | None = None
    if n >= 2:
        sd = float(np.std(values, ddof=1))
        half = float(st.t.ppf(0.5 + confidence / 2.0, n - 1)) * sd / math.sqrt(n)
        ci_low, ci_high = mean - half, mean + half
    return GroupSummary(
        group=group,
        n=n,
        n_missing=n_missing,
        mean=mean,
        sd=sd,
        median=median,
        q1=q1,
        q3=q3,
        min=float(np.min(values)),
        max=float(np.max(values)),
        mean_ci_low=ci_low,
        mean_ci_high=ci_high,
    )


def wilson_interval(count: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (as statsmodels ``proportion_confint(method="wilson")``)."""
    if n <= 0:
        raise ValueError("a rate needs at least one observation")
    z = float(st.norm.isf((1.0 - confidence) / 2.0))
    p = count / n
    z2 = z * z
    denominator = 1.0 + z2 / n
    centre = (p + z2 / (2.0 * n)) / denominator
    half = z * math.sqrt(p * (1.0 - p) / n + z2 / (4.0 * n * n)) / denominator
    return max(centre - half, 0.0), min(centre + half, 1.0)


def rate(group: str, level: str, count: int, n: int, n_missing: int = 0, confidence: float = 0.95) -> RateSummary:
    """Share of ``level`` in a group with its Wilson interval."""
    if n == 0:
        return RateSummary(group=group, level=level, n=0, count=0, n_missing=n_missing)
    low, high = wilson_interval(count, n, confidence)
    return RateSummary(
        group=group, level=level, n=n, count=count, rate=count / n, ci_low=low, ci_high=high, n_missing=n_missing
    )


__all__ = ["rate", "summarize", "wilson_interval"]
