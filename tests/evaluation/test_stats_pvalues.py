"""p-values: bounds instead of 0, formatting, Holm's adjustment (against statsmodels)."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as hst

from evaluation.stats import pvalues
from evaluation.stats.pvalues import FLOAT_FLOOR, PValue

from .holm_reference import statsmodels_holm


def test_underflow_is_a_bound_never_zero() -> None:
    p = pvalues.exact(0.0)
    assert p.is_bound and p.value == FLOAT_FLOOR and str(p) == "< 2.2e-308"
    q = pvalues.from_tail(0.0, -1000.0 * math.log(10.0))
    assert q.is_bound and q.value > 0.0 and q.log10 is not None and str(q) == "< 1e-1000"
    assert pvalues.from_tail(0.0, float("-inf")).value == FLOAT_FLOOR


def test_formatting() -> None:
    assert str(pvalues.exact(0.021425)) == "0.0214"
    assert str(pvalues.exact(3.66e-62)) == "3.66e-62"
    assert pvalues.format_p_apa(pvalues.exact(0.0214)) == "p = 0.021"
    assert pvalues.format_p_apa(pvalues.exact(1e-9)) == "p < 0.001"


def test_holm_leaves_out_missing_and_keeps_bounds() -> None:
    raw: list[PValue | None] = [pvalues.exact(0.01), None, pvalues.exact(0.04), PValue(value=1e-300, bound="upper")]
    adjusted = pvalues.holm(raw)
    assert adjusted[1] is None
    ref = statsmodels_holm([0.01, 0.04, 1e-300])
    assert [a.value for a in adjusted if a is not None] == [ref[0], ref[1], ref[2]]
    assert adjusted[3] is not None and adjusted[3].is_bound


@settings(max_examples=25, deadline=None)
@given(hst.lists(hst.floats(1e-12, 1.0), min_size=1, max_size=12))
def test_holm_matches_statsmodels(ps: list[float]) -> None:
    ours = [p.value for p in pvalues.holm([pvalues.exact(p) for p in ps]) if p is not None]
    ref = statsmodels_holm(ps)
    assert all(abs(a - b) < 1e-12 for a, b in zip(ours, ref, strict=True))
