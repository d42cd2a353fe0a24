"""Chi-square of independence, Cramér's V, power, pairwise 2 × 2 with Holm and Fisher, Wilson intervals."""

from __future__ import annotations

import importlib
import warnings
from typing import Any

import numpy as np
from scipy import stats as st
from statsmodels.stats.proportion import proportion_confint

from evaluation.stats import categorical, descriptive, power

from .conftest import close, num, pv
from .holm_reference import statsmodels_holm

GROUPS = ["yolo", "gemma", "gpt4"]
LEVELS = ["false", "true"]
# The paper's action-recommendation counts that reproduce its chi-square (2/44, 35/44, 41/44) ...
PAPER = np.array([[42, 2], [9, 35], [3, 41]])
# ... and Table 2 as printed, with a zero cell.
ZERO_CELL = np.array([[44, 0], [9, 35], [4, 40]])


def _frame(table: np.ndarray) -> Any:
    pd: Any = importlib.import_module("pandas")
    rows = [(g, lev) for gi, g in enumerate(GROUPS) for li, lev in enumerate(LEVELS) for _ in range(table[gi, li])]
    return pd.DataFrame(rows, columns=["g", "y"])


def test_chi_square_matches_scipy_and_pingouin(pg) -> None:
    for table in (PAPER, ZERO_CELL):
        ours, expected_min, _, _ = categorical.chi_square_test(table, GROUPS, LEVELS)
        ref = st.chi2_contingency(table, correction=False)
        assert close(ours.statistic, ref.statistic) and close(pv(ours.p), ref.pvalue) and ours.df == (2.0,)
        assert close(expected_min, ref.expected_freq.min())
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _, _, stats = pg.chi2_independence(_frame(table), x="g", y="y", correction=False)
        pearson = stats[stats.test == "pearson"].iloc[0]
        assert close(ours.statistic, pearson["chi2"]) and close(ours.effect_sizes["cramers_v"], pearson["cramer"])
        assert close(ours.power, pearson["power"])


def test_paper_counts_reproduce_the_papers_chi_square() -> None:
    ours, _, _, _ = categorical.chi_square_test(PAPER, GROUPS, LEVELS)
    assert round(num(ours.statistic), 2) == 82.92 and round(ours.effect_sizes["cramers_v"], 2) == 0.79


def test_zero_cells_are_not_shifted() -> None:
    ours, _, _, _ = categorical.chi_square_test(ZERO_CELL, GROUPS, LEVELS)
    shifted = st.chi2_contingency(ZERO_CELL + 0.5, correction=False).statistic
    assert close(ours.statistic, st.chi2_contingency(ZERO_CELL, correction=False).statistic)
    assert not close(ours.statistic, shifted)


def test_a_level_that_never_occurs_is_not_testable() -> None:
    table = np.array([[10, 0], [12, 0]])
    ours, _, _, notes = categorical.chi_square_test(table, ["a", "b"], LEVELS)
    assert ours.statistic is None and "every group" in (ours.reason or "")
    assert any("never occur" in n for n in notes)


def test_pairwise_two_by_two_with_holm_and_fisher() -> None:
    family = categorical.pairwise_chi_square(ZERO_CELL, GROUPS, LEVELS, positive=1)
    raw = []
    for row in family.comparisons:
        i, j = GROUPS.index(row.a), GROUPS.index(row.b)
        sub = ZERO_CELL[[i, j]]
        ref = st.chi2_contingency(sub, correction=False)
        assert close(row.statistic, ref.statistic) and close(pv(row.p), ref.pvalue)
        assert close(row.extra["fisher_p"], st.fisher_exact(sub).pvalue)
        assert close(row.estimate, sub[0, 1] / sub[0].sum() - sub[1, 1] / sub[1].sum())
        raw.append(ref.pvalue)
    for row, padj in zip(family.comparisons, statsmodels_holm(raw), strict=True):
        assert close(pv(row.p_adjusted), padj)


def test_pair_with_the_same_outcome_everywhere_is_left_out() -> None:
    table = np.array([[10, 0], [12, 0], [5, 5]])
    family = categorical.pairwise_chi_square(table, ["a", "b", "c"], LEVELS, positive=1)
    first = family.comparisons[0]
    assert first.p is None and first.p_adjusted is None and "same" in (first.reason or "")
    others = [pv(c.p) for c in family.comparisons[1:]]
    assert [pv(c.p_adjusted) for c in family.comparisons[1:]] == statsmodels_holm(others)


def test_wilson_interval_matches_statsmodels() -> None:
    for count, n in [(0, 44), (2, 44), (35, 44), (44, 44), (1, 3)]:
        low, high = descriptive.wilson_interval(count, n)
        ref = proportion_confint(count, n, alpha=0.05, method="wilson")
        assert close(low, ref[0]) and close(high, ref[1])


def test_chi_square_power_matches_statsmodels_and_pingouin(pg) -> None:
    from statsmodels.stats.power import GofChisquarePower

    for w, n, dof in [(0.3, 50, 2), (0.1, 132, 2), (0.2, 80, 1), (0.15, 200, 4)]:
        ours = power.chi2_power(w, n, dof, 0.05)
        assert close(ours, GofChisquarePower().power(effect_size=w, nobs=n, alpha=0.05, n_bins=dof + 1))
        assert close(ours, pg.power_chi2(dof=dof, w=w, n=n, alpha=0.05))
