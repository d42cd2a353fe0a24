"""How a figure of the paper reads when printed: its value in plain text at the precision it was printed with
(``paper_display``), and whether a recomputed value rounds to it (``at_precision``).

>>> at_precision(0.4449, 0.44, 0.01), at_precision(0.4451, 0.44, 0.01)
(True, False)
"""

from __future__ import annotations

import math

from evaluation.paper.figures import Figure
from evaluation.stats import formatting as fmt


def paper_display(f: Figure) -> str:
    """The printed value in plain text, without its surrounding words."""
    if f.display is not None:
        return f.display
    if f.value is None:
        return f.text
    prefix = {"=": "", "≈": "≈ ", "<": "< ", ">": "> ", "≪": "≪ ", "claim": ""}[f.relation]
    if isinstance(f.value, list):
        if f.unit == "s" and len(f.value) == 2:
            return fmt.mean_sd(f.value[0], f.value[1], "s")
        if f.id.startswith("t2.persons"):
            return f"{int(f.value[0])} ({100 * f.value[1]:.1f}%)"
        if f.unit == "fraction":
            return " vs ".join(_percent(v, f.resolution) for v in f.value)
        if f.resolution:
            return " vs ".join(_number(v, f.resolution) for v in f.value)
        return "(" + ", ".join(f"{v:g}" for v in f.value) + ")"
    v = float(f.value)
    if f.unit == "fraction":
        return prefix + _percent(v, f.resolution)
    if f.unit == "count":
        return prefix + str(int(v))
    if f.unit == "s" and f.role == "input":
        return prefix + fmt.mean_sd(v, None, "s")
    if f.unit == "ratio":
        if v >= 1e5 and f.resolution is None:
            return f"{prefix}10^{round(math.log10(v))}×"
        if v >= 1e3 and f.resolution == 1e3:
            return f"{prefix}{v / 1e3:.0f}k×"
        return prefix + (fmt.ratio(v) if v >= 1e3 else f"{_number(v, f.resolution)}×")
    return prefix + _number(v, f.resolution)


def _percent(v: float, resolution: float | None) -> str:
    decimals = 0 if resolution is None or resolution >= 0.01 else max(0, round(-math.log10(resolution)) - 2)
    if resolution is None:
        return f"{100 * v:g}%"
    return f"{100 * v:.{decimals}f}%"


def _number(v: float, resolution: float | None) -> str:
    if resolution is None:
        return f"{v:g}"
    decimals = max(0, round(-math.log10(resolution)))
    return f"{v:.{decimals}f}"


def at_precision(value: float, printed: float, resolution: float) -> bool:
    """Does ``value`` round (half up) to ``printed`` at ``resolution``?"""
    return abs(value - printed) <= resolution / 2 + 1e-12 * max(1.0, abs(printed))


__all__ = ["at_precision", "paper_display"]
