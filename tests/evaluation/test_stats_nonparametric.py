"""Kruskal–Wallis, Dunn (Holm) and Mann–Whitney U with rank-biserial r, against scipy, statsmodels and
pingouin (Dunn against an independent direct computation: neither scipy nor pingouin has Dunn's test)."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as hst
from scipy import stats as st

from evaluation.stats import nonparametric

from .conftest import close, frame, num, pv, pval
from .holm_reference import statsmodels_holm


def test_kruskal_matches_scipy_and_pingouin(groups3, pg) -> None:
    h, _ = nonparametric.kruskal_dunn(list(groups3), list(groups3.values()))
    ref = st.kruskal(*groups3.values())
    assert close(h.statistic, ref.statistic) and close(pv(h.p), ref.pvalue)
    pk = pg.kruskal(frame(groups3), dv="x", between="g")
    assert close(h.statistic, pk["H"].iloc[0]) and close(pv(h.p), pk["p_unc"].iloc[0])


def _dunn_reference(samples: list[np.ndarray]) -> tuple[list[float], list[float], list[float]]:
    """Dunn (1964) with the tie correction, written out directly."""
    pooled = np.concatenate(samples)
    ranks = st.rankdata(pooled)
    n = pooled.size
    _, ties = np.unique(pooled, return_counts=True)
    correction = (ties**3 - ties).sum() / (12.0 * (n - 1))
    bounds = np.cumsum([0] + [s.size for s in samples])
    mean_ranks = [ranks[bounds[i] : bounds[i + 1]].mean() for i in range(len(samples))]
    zs, ps = [], []
    for i, j in itertools.combinations(range(len(samples)), 2):
        se = math.sqrt((n * (n + 1) / 12.0 - correction) * (1 / samples[i].size + 1 / samples[j].size))
        z = (mean_ranks[i] - mean_ranks[j]) / se
        zs.append(z)
        ps.append(2 * st.norm.sf(abs(z)))
    adjusted = statsmodels_holm(ps)
    return zs, ps, adjusted


def test_dunn_matches_direct_formula_and_statsmodels_holm(groups3) -> None:
    _, dunn = nonparametric.kruskal_dunn(list(groups3), list(groups3.values()))
    zs, ps, adjusted = _dunn_reference(list(groups3.values()))
    for row, z, p, padj in zip(dunn.comparisons, zs, ps, adjusted, strict=True):
        assert close(row.statistic, z) and close(pv(row.p), p) and close(pv(row.p_adjusted), padj)


def test_mann_whitney_matches_scipy_and_pingouin(groups3, pg) -> None:
    family = nonparametric.pairwise_mann_whitney(list(groups3), list(groups3.values()))
    raw = []
    for row in family.comparisons:
        x, y = groups3[row.a], groups3[row.b]
        ref = st.mannwhitneyu(x, y, alternative="two-sided")
        assert close(row.statistic, ref.statistic) and close(pv(row.p), ref.pvalue)
        m = pg.mwu(x, y)
        assert close(row.statistic, m["U_val"].iloc[0]) and close(row.effect, m["RBC"].iloc[0])
        assert close(pv(row.p), m["p_val"].iloc[0])
        raw.append(ref.pvalue)
    for row, padj in zip(family.comparisons, statsmodels_holm(raw), strict=True):
        assert close(pv(row.p_adjusted), padj)


def test_mann_whitney_exact_for_small_groups_without_ties(pg) -> None:
    x = np.array([1.1, 2.3, 0.4, 5.6, 3.3])
    y = np.array([6.1, 7.2, 4.4, 8.9])
    row = nonparametric.mann_whitney("x", x, "y", y)
    ref = st.mannwhitneyu(x, y, alternative="two-sided")
    assert row.extra["exact"] == 1.0
    assert close(row.statistic, ref.statistic) and close(pv(row.p), ref.pvalue)
    assert close(row.effect, pg.mwu(x, y)["RBC"].iloc[0])


def test_huge_separation_gives_bounds_not_zero() -> None:
    rng = np.random.default_rng(1)
    a, b = rng.normal(0, 1, 20_000), rng.normal(100, 1, 20_000)
    row = nonparametric.mann_whitney("a", a, "b", b)
    assert st.mannwhitneyu(a, b).pvalue == 0.0  # scipy underflows
    assert pv(row.p) > 0.0 and pval(row.p).is_bound and num(pval(row.p).log10) < -308
    h, dunn = nonparametric.kruskal_dunn(["a", "b"], [a, b])
    assert pv(h.p) > 0.0 and pval(h.p).is_bound
    assert all(pv(c.p) > 0.0 for c in dunn.comparisons)


def test_all_values_tied() -> None:
    h, dunn = nonparametric.kruskal_dunn(["a", "b"], [np.ones(5), np.ones(4)])
    assert h.statistic is None and "equal" in (h.reason or "")
    assert dunn.comparisons == [] and dunn.reason
    row = nonparametric.mann_whitney("a", np.ones(5), "b", np.ones(4))
    assert row.p is None and "equal" in (row.reason or "")


@settings(max_examples=40, deadline=None)
@given(
    hst.lists(hst.integers(0, 6), min_size=1, max_size=12),
    hst.lists(hst.integers(0, 6), min_size=1, max_size=12),
    hst.lists(hst.integers(0, 6), min_size=1, max_size=12),
)
def test_property_rank_tests_match_scipy(a: list[int], b: list[int], c: list[int]) -> None:
    arrays = [np.array(v, dtype=float) for v in (a, b, c)]
    h, _ = nonparametric.kruskal_dunn(["a", "b", "c"], arrays)
    if len(set(a + b + c)) > 1:
        ref = st.kruskal(*arrays)
        assert close(h.statistic, ref.statistic, 1e-7) and abs(pv(h.p) - ref.pvalue) < 1e-9
    row = nonparametric.mann_whitney("a", arrays[0], "b", arrays[1])
    if len(set(a + b)) > 1:
        ref_u = st.mannwhitneyu(arrays[0], arrays[1], alternative="two-sided")
        assert close(row.statistic, ref_u.statistic) and abs(pv(row.p) - ref_u.pvalue) < 1e-9
