"""Statistics recomputable from published summary figures: one-way ANOVA, Welch's ANOVA, Tukey HSD and
Games–Howell from means, SDs and n; chi-square from counts; rates from counts; the range of a statistic over
the rounding of its inputs. Thin wrappers over :mod:`evaluation.stats`."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt
from scipy import optimize
from scipy import stats as st

from evaluation.stats import categorical, parametric
from evaluation.stats._typing import FloatArray
from evaluation.stats.models import OmnibusResult, PosthocResult


def moments(
    labels: Sequence[str], n: Sequence[int], means: Sequence[float], sds: Sequence[float]
) -> list[parametric.Moments]:
    return [parametric.Moments.from_sd(lab, k, m, s) for lab, k, m, s in zip(labels, n, means, sds, strict=True)]


def anova_f(n: npt.ArrayLike, means: npt.ArrayLike, sds: npt.ArrayLike) -> float:
    """Fisher's F from summaries (no p, no power: fast, for range searches)."""
    nn = np.asarray(n, dtype=np.float64)
    m = np.asarray(means, dtype=np.float64)
    v = np.asarray(sds, dtype=np.float64) ** 2
    grand = float((nn * m).sum() / nn.sum())
    ssb = float((nn * (m - grand) ** 2).sum())
    ssw = float(((nn - 1) * v).sum())
    k = len(nn)
    return float((ssb / (k - 1)) / (ssw / (nn.sum() - k)))


def anova(
    labels: Sequence[str], n: Sequence[int], means: Sequence[float], sds: Sequence[float], alpha: float = 0.05
) -> OmnibusResult:
    return parametric.one_way_anova(moments(labels, n, means, sds), alpha)


def welch(labels: Sequence[str], n: Sequence[int], means: Sequence[float], sds: Sequence[float]) -> OmnibusResult:
    return parametric.welch_anova(moments(labels, n, means, sds))


def tukey(labels: Sequence[str], n: Sequence[int], means: Sequence[float], sds: Sequence[float]) -> PosthocResult:
    return parametric.tukey_hsd(moments(labels, n, means, sds))


def games_howell(
    labels: Sequence[str], n: Sequence[int], means: Sequence[float], sds: Sequence[float]
) -> PosthocResult:
    return parametric.games_howell(moments(labels, n, means, sds))


def chi_square(counts: Sequence[int], n: Sequence[int], labels: Sequence[str], alpha: float = 0.05) -> OmnibusResult:
    """Chi-square of independence of a binary outcome across groups, from the positive counts."""
    table = np.array([[k_n - k, k] for k, k_n in zip(counts, n, strict=True)], dtype=np.int64)
    return categorical.chi_square_test(table, labels, ["no", "yes"], alpha)[0]


def p_of_f(f: float, df1: float, df2: float) -> float:
    return float(st.f.sf(f, df1, df2))


def p_of_chi2(chi2: float, df: float) -> float:
    return float(st.chi2.sf(chi2, df))


def counts_for_rate(rate: float, n: int, resolution: float) -> tuple[list[int], list[int]]:
    """Counts k out of n whose rate k/n rounds (half up) to ``rate`` at ``resolution``, and those that only
    truncate to it."""
    rounded, truncated = [], []
    for k in range(n + 1):
        r = k / n
        if abs(r - rate) <= resolution / 2 + 1e-12:
            rounded.append(k)
        elif rate - 1e-12 <= r < rate + resolution - 1e-12:
            truncated.append(k)
    return rounded, truncated


def binary_tables_with_chi2(target: float, resolution: float, n: int, k_groups: int) -> list[tuple[int, ...]]:
    """Every multiset of positive counts (k groups of n) whose chi-square rounds to ``target``."""
    hits = []
    for counts in itertools.combinations_with_replacement(range(n + 1), k_groups):
        total = sum(counts)
        if total in (0, n * k_groups):
            continue
        p = total / (n * k_groups)
        e1, e0 = n * p, n * (1 - p)
        chi2 = sum((c - e1) ** 2 / e1 + ((n - c) - e0) ** 2 / e0 for c in counts)
        if abs(chi2 - target) <= resolution / 2:
            hits.append(counts)
    return hits


def range_over_box(
    func: Callable[[FloatArray], float], centre: Sequence[float], half_widths: Sequence[float]
) -> tuple[float, float]:
    """Min and max of ``func`` over the box centre ± half_widths (the rounding of published inputs): all
    corners, then a bounded local search from the best corner and from the centre."""
    c = np.asarray(centre, dtype=np.float64)
    h = np.asarray(half_widths, dtype=np.float64)
    scale = np.where(h > 0, h, 1.0)

    def unit(z: FloatArray) -> float:
        return func(c + z * scale)

    corners = [np.array(signs, dtype=np.float64) for signs in itertools.product((-1.0, 1.0), repeat=c.size)]
    bounds = [(-1.0, 1.0) if hw > 0 else (0.0, 0.0) for hw in h]
    values = [unit(z * (h > 0)) for z in corners] + [unit(np.zeros_like(c))]
    low, high = min(values), max(values)
    for sign in (1.0, -1.0):
        for start in (np.zeros_like(c), corners[int(np.argmin([sign * v for v in values[:-1]]))] * (h > 0)):
            res = optimize.minimize(lambda z, s=sign: s * unit(z), start, bounds=bounds, method="L-BFGS-B")
            value = unit(np.clip(res.x, -1.0, 1.0))
            low, high = min(low, value), max(high, value)
    return low, high


def round_half_up(x: float, resolution: float) -> float:
    return math.floor(x / resolution + 0.5) * resolution


__all__ = [
    "anova",
    "anova_f",
    "binary_tables_with_chi2",
    "chi_square",
    "counts_for_rate",
    "games_howell",
    "moments",
    "p_of_chi2",
    "p_of_f",
    "range_over_box",
    "round_half_up",
    "tukey",
    "welch",
]
