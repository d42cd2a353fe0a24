"""p-values that never print as 0.

A p-value below the smallest normal double (about 2.2e-308) cannot be stored; neither can the tail of a
distribution that scipy evaluates by numerical integration below that integration's accuracy. In both cases
we keep an *upper bound* instead of a misleading 0, and, when the log of the tail is known, its log10.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from typing import Literal

from pydantic import BaseModel, ConfigDict

#: Smallest positive normal double. A computed p below this is reported as ``p < FLOAT_FLOOR``.
FLOAT_FLOOR = sys.float_info.min


class PValue(BaseModel):
    """A p-value, or an upper bound on it when it is too small to compute or represent."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    value: float
    """The p-value (``bound == "exact"``) or a value it is known to be below (``bound == "upper"``)."""
    bound: Literal["exact", "upper"] = "exact"
    log10: float | None = None
    """log10 of the p-value (exact) or of the bound, when known beyond the range of a double."""

    @property
    def is_bound(self) -> bool:
        return self.bound == "upper"

    def significant(self, alpha: float) -> bool:
        return self.value < alpha

    def __str__(self) -> str:
        return format_p(self)


def exact(p: float) -> PValue:
    """An exact p-value, clipped to [0, 1]; an underflowed 0 becomes the bound ``< FLOAT_FLOOR``."""
    p = float(p)
    if math.isnan(p):
        raise ValueError("p-value is NaN")
    p = min(max(p, 0.0), 1.0)
    if p < FLOAT_FLOOR:
        return PValue(value=FLOAT_FLOOR, bound="upper")
    return PValue(value=p)


def from_tail(sf: float, logsf: float | None = None) -> PValue:
    """A p-value from a survival function and, optionally, its log (for values beyond the double range)."""
    sf = float(sf)
    if sf >= FLOAT_FLOOR:
        return exact(sf)
    if logsf is not None and math.isfinite(logsf):
        return upper_bound_from_log10(logsf / math.log(10.0))
    return PValue(value=FLOAT_FLOOR, bound="upper")


def upper_bound_from_log10(log10_bound: float) -> PValue:
    """The bound ``p < 10**log10_bound``; stored as a double when representable."""
    value = 10.0**log10_bound if log10_bound > math.log10(FLOAT_FLOOR) else FLOAT_FLOOR
    return PValue(value=min(value, 1.0), bound="upper", log10=log10_bound)


def format_p(p: PValue, digits: int = 3) -> str:
    """``0.0214``, ``3.66e-62``, ``< 1e-450`` (a bound)."""
    if p.is_bound:
        if p.log10 is not None and p.log10 < math.log10(FLOAT_FLOOR):
            return f"< 1e{math.ceil(round(p.log10, 9))}"
        return f"< {_sig(p.value, 2)}"
    return _sig(p.value, digits)


def format_p_apa(p: PValue, threshold: float = 0.001) -> str:
    """The table style of the paper: ``p < 0.001`` or ``p = 0.021``."""
    if p.value < threshold:
        return f"p < {threshold:g}"
    return f"p = {p.value:.3f}"


def _sig(x: float, digits: int) -> str:
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e4:
        decimals = max(digits - 1 - math.floor(math.log10(abs(x))), 0)
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"


def holm(pvalues: Sequence[PValue | None]) -> list[PValue | None]:
    """Holm's step-down adjustment; ``None`` entries (not computable) are not part of the family.

    An adjusted value inherits the bound flag of the raw p-value that determines it.
    """
    present = [(i, p) for i, p in enumerate(pvalues) if p is not None]
    m = len(present)
    out: list[PValue | None] = [None] * len(pvalues)
    order = sorted(present, key=lambda item: item[1].value)
    running: PValue | None = None
    running_value = 0.0
    for rank, (index, p) in enumerate(order):
        factor = m - rank
        candidate = min(1.0, factor * p.value)
        if running is None or candidate > running_value:
            log10 = None if p.log10 is None else p.log10 + math.log10(factor)
            if candidate >= 1.0:
                running = PValue(value=1.0)
            elif p.is_bound:
                running = PValue(value=max(candidate, FLOAT_FLOOR), bound="upper", log10=log10)
            else:
                running = exact(candidate)
            running_value = candidate
        out[index] = running
    return out


__all__ = [
    "FLOAT_FLOOR",
    "PValue",
    "exact",
    "format_p",
    "format_p_apa",
    "from_tail",
    "holm",
    "upper_bound_from_log10",
]
