"""Number formatting for the report tables (plain text with ±, µ, ×, χ²; LaTeX conversion is separate)."""

from __future__ import annotations

import math

_TIME_SCALE = {"s": 1.0, "ms": 1e-3, "µs": 1e-6}


def sig(x: float | None, digits: int = 3) -> str:
    """``x`` to ``digits`` significant figures, in fixed notation between 1e-3 and 1e6."""
    if x is None:
        return "–"
    if x == 0 or not math.isfinite(x):
        return f"{x:g}"
    magnitude = math.floor(math.log10(abs(x)))
    if -3 <= magnitude < 6:
        decimals = max(digits - 1 - magnitude, 0)
        return f"{x:.{decimals}f}"
    return f"{x:.{digits - 1}e}"


def fixed(x: float | None, decimals: int) -> str:
    return "–" if x is None else f"{x:.{decimals}f}"


def time_unit(seconds: float) -> str:
    """The unit the paper would print a duration in: µs below 1 ms, ms below 1 s, else s."""
    a = abs(seconds)
    if a < 1e-3:
        return "µs"
    if a < 1.0:
        return "ms"
    return "s"


def mean_sd(mean: float | None, sd: float | None, unit: str | None = None) -> str:
    """``29.5 ± 9.4 µs`` (mean to 3 significant figures, SD to the same decimals); durations rescaled."""
    if mean is None:
        return "–"
    suffix = ""
    if unit in _TIME_SCALE:
        seconds = mean * _TIME_SCALE[unit]
        shown = time_unit(seconds)
        factor = _TIME_SCALE[unit] / _TIME_SCALE[shown]
        mean *= factor
        sd = None if sd is None else sd * factor
        suffix = f" {shown}"
    elif unit:
        suffix = f" {unit}"
    text = sig(mean, 3)
    decimals = len(text.split(".")[1]) if "." in text and "e" not in text else 0
    if sd is None:
        return f"{text}{suffix}"
    sd_text = f"{sd:.{decimals}f}" if "e" not in text else sig(sd, 2)
    if sd > 0 and float(sd_text) == 0.0:
        sd_text = sig(sd, 2)
    return f"{text} ± {sd_text}{suffix}"


def ratio(r: float) -> str:
    """``50.2k×``, ``168k×``, ``3.34×``."""
    if r >= 1e6:
        return f"{sig(r / 1e6, 3)}M×"
    if r >= 1e3:
        return f"{sig(r / 1e3, 3)}k×"
    return f"{sig(r, 3)}×"


def percent(rate: float | None, decimals: int = 1) -> str:
    return "–" if rate is None else f"{100.0 * rate:.{decimals}f}%"


EFFECT_NAMES = {
    "eta_squared": "η²",
    "omega_squared": "ω²",
    "cohen_f": "Cohen's f",
    "eta_squared_h": "η²(H)",
    "epsilon_squared": "ε²",
    "cramers_v": "Cramér's V",
    "cohens_w": "Cohen's w",
}


def effect_name(key: str) -> str:
    return EFFECT_NAMES.get(key, key.replace("_", " "))


def df_text(df: tuple[float, ...]) -> str:
    return ", ".join(str(int(d)) if float(d).is_integer() else f"{d:.2f}" for d in df)


__all__ = ["EFFECT_NAMES", "df_text", "effect_name", "fixed", "mean_sd", "percent", "ratio", "sig", "time_unit"]
