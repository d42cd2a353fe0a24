"""Shapiro–Wilk and Levene against scipy and pingouin; the cases where they cannot run."""

from __future__ import annotations

import numpy as np
from scipy import stats as st

from evaluation.stats import assumptions

from .conftest import close, frame, pv


def test_shapiro_matches_scipy_and_pingouin(groups3, pg) -> None:
    norm = pg.normality(frame(groups3), dv="x", group="g")
    for label, values in groups3.items():
        ours = assumptions.shapiro_wilk(label, values)
        ref = st.shapiro(values)
        assert close(ours.statistic, ref.statistic) and close(pv(ours.p), ref.pvalue)
        assert close(pv(ours.p), norm.loc[label, "pval"])


def test_levene_matches_scipy_and_pingouin(groups3, pg) -> None:
    ours = assumptions.levene(list(groups3.values()))
    ref = st.levene(*groups3.values(), center="median")
    assert close(ours.statistic, ref.statistic) and close(pv(ours.p), ref.pvalue)
    hom = pg.homoscedasticity(frame(groups3), dv="x", group="g")
    assert close(pv(ours.p), hom["pval"].iloc[0])
    mean_centred = assumptions.levene(list(groups3.values()), center="mean")
    assert close(mean_centred.statistic, st.levene(*groups3.values(), center="mean").statistic)


def test_shapiro_cannot_run_on_tiny_or_constant_groups() -> None:
    assert "at least 3" in (assumptions.shapiro_wilk("a", np.array([1.0, 2.0])).reason or "")
    constant = assumptions.shapiro_wilk("a", np.full(10, 3.0))
    assert constant.p is None and "equal" in (constant.reason or "")


def test_shapiro_large_sample_is_flagged() -> None:
    big = assumptions.shapiro_wilk("a", np.random.default_rng(0).normal(size=6000))
    assert big.p is not None and "5000" in (big.reason or "")


def test_levene_without_any_spread() -> None:
    result = assumptions.levene([np.full(4, 1.0), np.full(5, 2.0)])
    assert result.p is None and "constant" in (result.reason or "")


def test_descriptives_match_numpy_and_scipy(groups3) -> None:
    from evaluation.stats.descriptive import summarize

    for label, values in groups3.items():
        s = summarize(label, values)
        low, high = st.t.interval(0.95, values.size - 1, loc=values.mean(), scale=st.sem(values))
        assert close(s.mean, float(np.mean(values))) and close(s.sd, float(np.std(values, ddof=1)))
        assert close(s.median, float(np.median(values))) and close(s.mean_ci_low, low) and close(s.mean_ci_high, high)
    assert summarize("empty", np.array([])).mean is None
    assert summarize("one", np.array([2.0])).sd is None
