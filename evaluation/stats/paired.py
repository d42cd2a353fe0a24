"""A paired comparison of two conditions measured on the same units (scenes, flights): the Wilcoxon signed-rank
test, the mean difference and the matched-pairs rank-biserial correlation, with its p-value as ``eval stats``
prints it (:func:`~evaluation.stats.pvalues.format_p`).

>>> r = paired_test("before", [3.0, 4.0, 5.0, 6.0, 7.0, 8.0], "after", [2.0, 2.5, 4.0, 4.0, 6.5, 5.0])
>>> r.test, r.n, round(r.mean_difference, 3), r.p_text
('Wilcoxon signed-rank', 6, -1.5, '0.0312')
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict
from scipy import stats

from evaluation.stats.pvalues import PValue, exact, format_p


class PairedResult(BaseModel):
    """``b`` against ``a`` on the same units: the effect is oriented as ``b`` minus ``a``."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    a: str
    b: str
    test: str
    n: int
    mean_a: float
    mean_b: float
    mean_difference: float
    rank_biserial: float
    statistic: float | None
    p: PValue
    p_text: str
    note: str = ""

    def significant(self, alpha: float = 0.05) -> bool:
        return self.p.significant(alpha)

    def line(self) -> str:
        """One line for a report: the means, the effect and the p-value."""
        return (f"{self.b} vs {self.a} ({self.test}, n = {self.n} pairs): mean {self.mean_a:.4g} → {self.mean_b:.4g}, "
                f"difference {self.mean_difference:+.4g}, rank-biserial r = {self.rank_biserial:+.2f}, "
                f"p = {self.p_text}" + (f" ({self.note})" if self.note else ""))  # fmt: skip


def paired_test(a_label: str, a: Sequence[float], b_label: str, b: Sequence[float]) -> PairedResult:
    """Compare paired samples; pairs with a missing or non-finite value are dropped. All differences zero: p = 1."""
    pairs = [(float(x), float(y)) for x, y in zip(a, b, strict=True) if math.isfinite(x) and math.isfinite(y)]
    if not pairs:
        raise ValueError(f"{a_label} vs {b_label}: no complete pair to compare")
    xa, xb = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    d = xb - xa
    nonzero = d[d != 0]
    note, statistic, p = "", None, exact(1.0)
    if nonzero.size == 0:
        note, r = "every pair is equal", 0.0
    else:
        ranks = stats.rankdata(np.abs(nonzero))
        r = float((ranks[nonzero > 0].sum() - ranks[nonzero < 0].sum()) / ranks.sum())
        res = stats.wilcoxon(xb, xa, zero_method="wilcox")
        statistic, p = float(res.statistic), exact(float(res.pvalue))
        if nonzero.size < d.size:
            note = f"{d.size - nonzero.size} tied pairs left out of the ranks"
    return PairedResult(a=a_label, b=b_label, test="Wilcoxon signed-rank", n=len(pairs), mean_a=float(xa.mean()),
                        mean_b=float(xb.mean()), mean_difference=float(d.mean()), rank_biserial=r,
                        statistic=statistic, p=p, p_text=format_p(p), note=note)  # fmt: skip


__all__ = ["PairedResult", "paired_test"]
