"""ANOVA, Welch's ANOVA, Tukey HSD, Games–Howell, Cohen's d / Hedges' g and ANOVA power, cross-checked against
scipy, statsmodels and pingouin on fixed data to 1e-9."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hst
from scipy import stats as st

from evaluation.stats import parametric, power
from evaluation.stats import studentized_range as srange
from evaluation.stats.parametric import Moments

from .conftest import close, frame, num, pv, pval


def test_anova_matches_scipy_statsmodels_pingouin(groups3, moments3, pg) -> None:
    from statsmodels.stats.oneway import anova_oneway

    ours = parametric.one_way_anova(moments3)
    ref = st.f_oneway(*groups3.values())
    assert close(ours.statistic, ref.statistic) and close(pv(ours.p), ref.pvalue)
    sm = anova_oneway(list(groups3.values()), use_var="equal")
    assert close(ours.statistic, sm.statistic) and close(pv(ours.p), sm.pvalue)
    assert ours.df == (2.0, 49.0)
    pa = pg.anova(frame(groups3), dv="x", between="g", detailed=True)
    assert close(ours.statistic, pa["F"][0]) and close(ours.effect_sizes["eta_squared"], pa["np2"][0])


def test_welch_matches_statsmodels_and_pingouin(groups3, moments3, pg) -> None:
    from statsmodels.stats.oneway import anova_oneway

    ours = parametric.welch_anova(moments3)
    sm = anova_oneway(list(groups3.values()), use_var="unequal")
    assert close(ours.statistic, sm.statistic) and close(pv(ours.p), sm.pvalue)
    assert close(ours.df[1], sm.df[1])
    pw = pg.welch_anova(frame(groups3), dv="x", between="g")
    assert close(ours.statistic, pw["F"][0]) and close(pv(ours.p), pw["p_unc"][0]) and close(ours.df[1], pw["ddof2"][0])


def test_tukey_matches_scipy_and_pingouin(groups3, moments3, pg) -> None:
    ours = parametric.tukey_hsd(moments3)
    ref = st.tukey_hsd(*groups3.values())
    ci = ref.confidence_interval(0.95)
    pt = pg.pairwise_tukey(frame(groups3), dv="x", between="g")
    for row, (i, j) in zip(ours.comparisons, itertools.combinations(range(3), 2), strict=True):
        assert close(row.estimate, ref.statistic[i, j])
        assert close(pv(row.p), ref.pvalue[i, j])
        assert close(row.ci_low, ci.low[i, j]) and close(row.ci_high, ci.high[i, j])
        match = pt[(row.a == pt.A) & (row.b == pt.B)].iloc[0]
        assert close(pv(row.p), match["p_tukey"]) and close(row.extra["se"], match["se"])
        assert close(row.statistic, abs(match["T"]) * math.sqrt(2))


def test_games_howell_matches_pingouin_and_scipy(groups3, moments3, pg) -> None:
    ours = parametric.games_howell(moments3)
    gh = pg.pairwise_gameshowell(frame(groups3), dv="x", between="g")
    ref = st.tukey_hsd(*groups3.values(), equal_var=False)
    ci = ref.confidence_interval(0.95)
    for row, (i, j) in zip(ours.comparisons, itertools.combinations(range(3), 2), strict=True):
        match = gh[(row.a == gh.A) & (row.b == gh.B)].iloc[0]
        assert close(row.statistic, match["T"]) and close(row.df, match["df"]) and close(pv(row.p), match["pval"])
        assert close(row.extra["se"], match["se"])
        assert close(pv(row.p), ref.pvalue[i, j])
        assert close(row.ci_low, ci.low[i, j]) and close(row.ci_high, ci.high[i, j])


def test_cohen_d_and_hedges_g_match_pingouin(groups3, moments3, pg) -> None:
    effects = parametric.pairwise_effects(moments3)
    for e in effects:
        x, y = groups3[e.a], groups3[e.b]
        assert close(e.cohen_d, pg.compute_effsize(x, y, eftype="cohen"))
        assert close(e.hedges_g, pg.compute_effsize(x, y, eftype="hedges"))


def test_anova_power_matches_statsmodels_and_pingouin(pg) -> None:
    from statsmodels.stats.power import FTestAnovaPower

    for eta2, n in [(0.05, 20), (0.1, 44), (0.02, 100)]:
        ours = power.anova_power(eta2, 3 * n, 3, 0.05)
        f = math.sqrt(eta2 / (1 - eta2))
        assert close(ours, FTestAnovaPower().power(effect_size=f, nobs=3 * n, alpha=0.05, k_groups=3))
        assert close(ours, pg.power_anova(eta_squared=eta2, k=3, n=n, alpha=0.05))


@pytest.mark.parametrize("k", [2, 3, 4, 7, 12])
@pytest.mark.parametrize("df", [2, 3.5, 9, 43, 129, 1000, 99_999, 250_000])
def test_studentized_range_cdf_matches_scipy(k: int, df: float) -> None:
    for q in (0.2, 1.0, 2.5, 3.5, 5.0, 8.0):
        assert abs(srange.cdf(q, k, df) - st.studentized_range.cdf(q, k, df)) < 1e-9


@pytest.mark.parametrize(("k", "df"), [(3, 129), (3, 41.7), (5, 12), (2, 7), (4, 1.5), (25, 60)])
def test_studentized_range_ppf_matches_scipy(k: int, df: float) -> None:
    assert close(srange.ppf(0.95, k, df), st.studentized_range.ppf(0.95, k, df))


def test_tiny_tukey_p_is_a_true_upper_bound() -> None:
    p = parametric.studentized_range_p(60.0, 3, 129)
    assert p.is_bound and p.value <= parametric.STUDENTIZED_RANGE_FLOOR
    # the union bound is at least the exact tail of one pair, computable with the t distribution
    assert p.log10 is not None and p.log10 >= math.log10(2.0) + st.t.logsf(60.0 / math.sqrt(2.0), 129) / math.log(10)
    assert str(p).startswith("< ")


def test_anova_from_summaries_equals_raw_data(groups3, moments3) -> None:
    """The paper path (means, SDs, n) and the raw path give the same F."""
    via_sd = [Moments.from_sd(m.label, m.n, m.mean, math.sqrt(m.var)) for m in moments3]
    assert close(parametric.one_way_anova(via_sd).statistic, num(parametric.one_way_anova(moments3).statistic))


@settings(max_examples=40, deadline=None)
@given(
    hst.lists(
        hst.lists(hst.floats(-1e3, 1e3, allow_nan=False).map(lambda v: round(v, 1)), min_size=3, max_size=15),
        min_size=2,
        max_size=4,
    )
)
def test_anova_property_matches_scipy(data: list[list[float]]) -> None:
    arrays = [np.array(d) for d in data]
    ours = parametric.one_way_anova([Moments.of(str(i), a) for i, a in enumerate(arrays)])
    if sum(float(np.var(a)) for a in arrays) == 0.0:
        assert ours.statistic is None and ours.reason
        return
    ref = st.f_oneway(*arrays)
    assert close(ours.statistic, ref.statistic, 1e-7)
    if math.isnan(ref.pvalue):  # scipy's F came out as -1e-33 (rounding); ours is exactly 0 with p = 1
        assert ours.statistic == 0.0 and pv(ours.p) == 1.0
        return
    assert abs(pv(ours.p) - ref.pvalue) < 1e-9 or pval(ours.p).is_bound
