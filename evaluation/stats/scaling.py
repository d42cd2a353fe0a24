"""Outcomes too large or too small for double arithmetic (1e160, 1e-320): analysed on the values times a power
of two, which is exact, and the results that carry the data's unit multiplied back.

Every test here is scale-invariant (F, H, q, t, W, U, d and their p-values do not change when all values are
multiplied by one positive number), but their sums of squares overflow past about 1e154 and underflow below
about 1e-154; scaled so the largest value is near 1, they do neither. A result that no double can hold in the
data's unit (a difference of 3e308) is left out, with a note.

>>> import numpy as np
>>> exponent([np.array([1e160, 2e160])]) > 0, exponent([np.array([1.0, 2.0])])
(True, 0)
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from evaluation.stats._typing import FloatArray
from evaluation.stats.models import ContinuousAnalysis, GroupSummary, PairwiseResult, PosthocResult

#: Values whose largest size lies within 2**±SAFE_EXPONENT are analysed as they are: their squares, and sums of
#: a great many squares, are normal doubles.
SAFE_EXPONENT = 256
#: Pairwise estimates in the data's unit; the others (mean-rank differences) are unit-free.
UNIT_ESTIMATES = frozenset({"mean difference", "median difference"})
OVERFLOW_NOTE = (
    "some results in the data's unit exceed the largest double (about 1.8e308) and are left out (–); "
    "the tests, which do not depend on the unit, are unaffected"
)


def exponent(samples: Sequence[FloatArray]) -> int:
    """0 when the values can be analysed as they are; else the ``e`` with the largest ``|value| / 2**e`` in
    [0.5, 1)."""
    largest = max((float(np.max(np.abs(s))) for s in samples if s.size), default=0.0)
    if largest == 0.0 or not math.isfinite(largest) or 2.0**-SAFE_EXPONENT <= largest <= 2.0**SAFE_EXPONENT:
        return 0
    return math.frexp(largest)[1]


def scaled(samples: Sequence[FloatArray], e: int) -> list[FloatArray]:
    """Every value times ``2**-e`` (exact, but for values more than 2**1000 below the largest, which vanish)."""
    return [np.ldexp(s, -e) for s in samples]


def own_scale(values: FloatArray) -> tuple[FloatArray, int]:
    """One group's values scaled for its own descriptives and normality test (whatever the other groups' size)."""
    e = exponent([values])
    return (scaled([values], e)[0] if e else values), e


def note(e: int) -> str:
    return (
        f"the values are too {'large' if e > 0 else 'small'} for double arithmetic as they are: every test was "
        f"computed on them times 2^{-e} (exact; the tests do not depend on the unit) and the means, SDs, "
        "differences and intervals multiplied back"
    )


class _Back:
    """Multiplies results by ``2**e``, remembering whether any overflowed."""

    def __init__(self, e: int) -> None:
        self.e = e
        self.overflowed = False

    def __call__(self, x: float | None) -> float | None:
        if x is None:
            return None
        try:
            value = math.ldexp(x, self.e)
        except OverflowError:
            value = math.inf
        if not math.isfinite(value):
            self.overflowed = True
            return None
        return value

    def summary(self, g: GroupSummary) -> GroupSummary:
        fields = ("mean", "sd", "median", "q1", "q3", "min", "max", "mean_ci_low", "mean_ci_high")
        return g.model_copy(update={f: self(getattr(g, f)) for f in fields})

    def pair(self, c: PairwiseResult) -> PairwiseResult:
        if c.estimate_name not in UNIT_ESTIMATES:
            return c
        extra = dict(c.extra)
        if "se" in extra:
            se = self(extra.pop("se"))
            if se is not None:
                extra["se"] = se
        update = {f: self(getattr(c, f)) for f in ("estimate", "ci_low", "ci_high")}
        return c.model_copy(update={**update, "extra": extra})

    def family(self, f: PosthocResult) -> PosthocResult:
        return f.model_copy(update={"comparisons": [self.pair(c) for c in f.comparisons]})


def summary_in_unit(summary: GroupSummary, e: int) -> GroupSummary:
    """A group's descriptives of its values times ``2**-e``, in the data's unit (what overflows left out)."""
    return _Back(e).summary(summary) if e else summary


def in_unit(analysis: ContinuousAnalysis, e: int) -> ContinuousAnalysis:
    """``analysis`` of the values times ``2**-e`` in the data's own unit, with a note saying how it was made;
    its group summaries are already in the data's unit."""
    if e == 0:
        return analysis
    back = _Back(e)
    overflowed = any(g.n >= 2 and g.mean_ci_low is None for g in analysis.groups)
    update: dict[str, object] = {
        "tukey": back.family(analysis.tukey),
        "games_howell": back.family(analysis.games_howell),
        "mann_whitney": back.family(analysis.mann_whitney),
    }
    overflowed = overflowed or back.overflowed
    update["notes"] = [*analysis.notes, note(e), *([OVERFLOW_NOTE] if overflowed else [])]
    return analysis.model_copy(update=update)


__all__ = [
    "OVERFLOW_NOTE",
    "SAFE_EXPONENT",
    "UNIT_ESTIMATES",
    "exponent",
    "in_unit",
    "note",
    "own_scale",
    "scaled",
    "summary_in_unit",
]
