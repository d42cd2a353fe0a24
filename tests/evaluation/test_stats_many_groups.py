"""The documented limit of 100 groups is analysed in full, and the fast studentized range behind Tukey HSD and
Games–Howell agrees with scipy and with itself one value at a time."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as st

from evaluation.stats import analyze, studentized_range
from evaluation.stats.columns import MAX_GROUPS
from evaluation.stats.dataset import Dataset


def test_the_documented_maximum_of_groups_is_analysed_in_full() -> None:
    rng = np.random.default_rng(7)
    groups = {f"g{i:03d}": rng.normal(i % 7, 1.0 + (i % 3), 6) for i in range(MAX_GROUPS)}
    (c,) = analyze(Dataset.from_groups(groups)).continuous
    pairs = MAX_GROUPS * (MAX_GROUPS - 1) // 2
    for family in (c.tukey, c.games_howell, c.dunn, c.mann_whitney):
        assert len(family.comparisons) == pairs and all(p.p is not None for p in family.comparisons)
    some = c.games_howell.comparisons[:: pairs // 7]
    for pair in some:  # each interval as the exact quantile at the pair's own df gives it
        assert pair.df is not None and pair.ci_low is not None and pair.ci_high is not None
        q = studentized_range.ppf(0.95, MAX_GROUPS, pair.df)
        half = q / np.sqrt(2.0) * pair.extra["se"]
        assert pair.ci_high - pair.ci_low == pytest.approx(2.0 * half, rel=1e-7)


@pytest.mark.parametrize("k", [30, 100])
def test_the_fast_studentized_range_matches_scipy_beyond_20_groups(k: int) -> None:
    for df in (3.0, 40.0):
        for q in (3.0, 7.0):
            assert studentized_range.cdf(q, k, df) == pytest.approx(float(st.studentized_range.cdf(q, k, df)), abs=1e-8)


@pytest.mark.parametrize("k", [3, 30, 100])
def test_the_vectorised_forms_agree_with_one_value_at_a_time(k: int) -> None:
    rng = np.random.default_rng(k)
    df = np.exp(rng.uniform(np.log(2.1), np.log(9e4), 40))
    q = rng.uniform(0.3, 12.0, 40)
    assert studentized_range.sf_many(q, k, df) == pytest.approx(
        [studentized_range.sf(a, k, d) for a, d in zip(q, df, strict=True)],
        abs=5e-11,  # the integral's own accuracy; p below 1e-10 becomes a bound
    )
    assert studentized_range.ppf_many(0.95, k, df) == pytest.approx(
        [studentized_range.ppf(0.95, k, d) for d in df[:8]] + list(studentized_range.ppf_many(0.95, k, df[8:])),
        rel=1e-7,
    )


@pytest.mark.parametrize("k", [2, 3, 20, 100])
def test_the_inner_integrals_table_is_the_integral(k: int) -> None:
    """:func:`sf_many` reads the inner integral from a piecewise table: at random points, at every piece's ends and
    far past the table, it is the integral itself to 1e-13."""
    table = studentized_range._range_cdf_table(k)
    ends = np.arange(studentized_range._TABLE_PIECES + 1) * studentized_range._TABLE_W / studentized_range._TABLE_PIECES
    w = np.concatenate(
        [np.random.default_rng(k).uniform(0.0, 20.0, 5000), ends, np.maximum(ends - 1e-12, 0.0), [1e-9, 0.0, 40.0, 1e6]]
    )
    assert np.abs(table(w) - studentized_range._range_cdf_infinite_df(w, k)).max() < 1e-13
