"""Calibrated confidence: a monotone map from a detector's raw score to the probability that a detection is a real
person, fitted on renders (isotonic regression, :func:`scipy.optimize.isotonic_regression`), and the measures of
how well a confidence is calibrated (expected calibration error, the reliability diagram's bins).

The World Model's ``conf`` is the calibrated value: a track at 0.8 is a person four times in five.

One raw score does not mean the same for every size: a detector is surer of a large person than its score says,
and less sure of a tiny one. With ``size_edges_px``, each band of box sizes (the box's longer side) has a map of
its own, fitted on that band's detections; a score given without its size uses the map of all sizes.

>>> import numpy as np
>>> cal = Calibration.fit(np.array([0.1, 0.2, 0.3, 0.6, 0.7, 0.9]), np.array([0, 0, 1, 0, 1, 1]))
>>> cal.apply(np.array([0.1, 0.65, 0.95])).round(2).tolist()
[0.0, 0.75, 1.0]
>>> Calibration.model_validate(cal.model_dump()) == cal
True
>>> sized = Calibration.fit(np.array([0.4, 0.4, 0.4, 0.4]), np.array([0, 0, 1, 1]), np.array([5, 5, 50, 50]),
...                         size_edges_px=[20.0], min_band=2)
>>> sized.apply(np.array([0.4, 0.4]), np.array([5.0, 50.0])).tolist(), sized.apply(np.array([0.4])).tolist()
([0.0, 1.0], [0.5])
>>> round(expected_calibration_error(np.array([0.9, 0.9, 0.1, 0.1]), np.array([1, 1, 0, 0])), 3)
0.1
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, model_validator

FloatArray = NDArray[np.float64]


MIN_BAND = 200
"""Fewest detections a size band is fitted on; a band with fewer takes the map of all sizes."""


def _check_curve(scores: list[float], probs: list[float], where: str) -> None:
    s, p = np.asarray(scores), np.asarray(probs)
    if len(s) != len(p):
        raise ValueError(f"{where}: {len(s)} scores but {len(p)} probabilities")
    if not (np.all(np.diff(s) > 0) and np.all(np.diff(p) >= 0) and np.all((p >= 0) & (p <= 1))):
        raise ValueError(f"{where}: scores must increase and probabilities be non-decreasing in 0-1")


def long_sides(boxes: NDArray[np.floating]) -> FloatArray:
    """The longer side of each box (N×4 corners, pixels): the size a calibration by size reads, fitted and applied
    alike."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])


def size_bands(edges_px: list[float], long_px: NDArray[np.floating]) -> NDArray[np.intp]:
    """Each size's band: 0 under the first edge, ``len(edges_px)`` at or over the last."""
    return np.searchsorted(np.asarray(edges_px, dtype=np.float64), np.asarray(long_px, dtype=np.float64), side="right")


class SizeBand(BaseModel):
    """The map of one band of box sizes, as :class:`Calibration`'s own ``scores`` and ``probs``."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scores: list[float] = Field(min_length=1)
    probs: list[float] = Field(min_length=1)


class Calibration(BaseModel):
    """A non-decreasing piecewise-linear map from raw score to probability: ``scores`` are its knots (increasing),
    ``probs`` the values there (non-decreasing, 0–1); below the first knot the first value, above the last the last.
    With ``size_edges_px`` (increasing), ``by_size`` holds one map more than there are edges: the first for boxes
    whose longer side is under the first edge, the last for those at or over the last."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    method: str = "isotonic"
    scores: list[float] = Field(min_length=1)
    probs: list[float] = Field(min_length=1)
    size_edges_px: list[float] = Field(default_factory=list)
    by_size: list[SizeBand] = Field(default_factory=list)

    @model_validator(mode="after")
    def _monotone(self) -> Calibration:
        _check_curve(self.scores, self.probs, "calibration")
        for k, band in enumerate(self.by_size):
            _check_curve(band.scores, band.probs, f"calibration: by_size[{k}]")
        edges = np.asarray(self.size_edges_px)
        if not (np.all(edges > 0) and np.all(np.diff(edges) > 0)):
            raise ValueError("calibration: size_edges_px must be positive and increasing")
        if (self.size_edges_px or self.by_size) and len(self.by_size) != len(edges) + 1:
            raise ValueError(f"calibration: {len(edges)} size edges need {len(edges) + 1} maps in by_size, "
                             f"not {len(self.by_size)}")  # fmt: skip
        return self

    @classmethod
    def identity(cls) -> Calibration:
        """The map that leaves scores as they are."""
        return cls(method="identity", scores=[0.0, 1.0], probs=[0.0, 1.0])

    @classmethod
    def fit(
        cls,
        scores: NDArray[np.floating],
        labels: NDArray[Any],
        long_px: NDArray[np.floating] | None = None,
        *,
        size_edges_px: list[float] | None = None,
        min_band: int = MIN_BAND,
    ) -> Calibration:
        """Isotonic regression of ``labels`` (1: a true person) on ``scores``, with tied scores pooled first; with
        ``long_px`` (each box's longer side) and ``size_edges_px``, also one per band of sizes."""
        if len(scores) == 0:
            raise ValueError("calibration: no scores to fit")
        every = _isotonic(scores, labels)
        if long_px is None or not size_edges_px:
            return cls(scores=every[0], probs=every[1])
        band = size_bands(size_edges_px, long_px)
        y = np.asarray(labels, dtype=np.float64)
        curves = []
        for k in range(len(size_edges_px) + 1):
            inside = band == k
            fitted = int(inside.sum()) >= max(min_band, 1)
            knots, probs = _isotonic(np.asarray(scores)[inside], y[inside]) if fitted else every
            curves.append(SizeBand(scores=knots, probs=probs))
        return cls(scores=every[0], probs=every[1], size_edges_px=list(size_edges_px), by_size=curves)

    def apply(self, scores: NDArray[np.floating], long_px: NDArray[np.floating] | None = None) -> FloatArray:
        """The calibrated probability of each raw score; with ``long_px`` (each box's longer side, pixels), by the
        map of its size band."""
        raw = np.asarray(scores, dtype=np.float64)
        if long_px is None or not self.by_size:
            return np.interp(raw, self.scores, self.probs)
        band = size_bands(self.size_edges_px, long_px)
        out = np.empty(raw.shape, np.float64)
        for k, curve in enumerate(self.by_size):
            inside = band == k
            out[inside] = np.interp(raw[inside], curve.scores, curve.probs)
        return out


def _isotonic(scores: NDArray[np.floating], labels: NDArray[Any]) -> tuple[list[float], list[float]]:
    """The knots and values of the isotonic fit of ``labels`` on ``scores`` (tied scores pooled first)."""
    from scipy.optimize import isotonic_regression

    knots, inverse = np.unique(np.asarray(scores, dtype=np.float64), return_inverse=True)
    counts = np.bincount(inverse).astype(np.float64)
    means = np.bincount(inverse, weights=np.asarray(labels, dtype=np.float64)) / counts
    fitted = np.clip(isotonic_regression(means, weights=counts).x, 0.0, 1.0)
    keep = np.r_[True, np.diff(fitted) > 0] | np.r_[np.diff(fitted) > 0, True]
    return knots[keep].tolist(), np.maximum.accumulate(fitted[keep]).tolist()


@dataclass(frozen=True)
class Reliability:
    """A reliability diagram's bins: mean confidence, observed frequency and count in each non-empty bin."""

    confidence: FloatArray
    frequency: FloatArray
    count: NDArray[np.int64]


def reliability(conf: NDArray[np.floating], labels: NDArray[Any], bins: int = 10) -> Reliability:
    """Confidences put in ``bins`` equal-width bins over 0–1: each bin's mean confidence and share of true ones."""
    c = np.asarray(conf, dtype=np.float64)
    y = np.asarray(labels, dtype=np.float64)
    index = np.minimum((c * bins).astype(np.int64), bins - 1)
    count = np.bincount(index, minlength=bins)
    present = count > 0
    sums = np.bincount(index, weights=c, minlength=bins)[present]
    hits = np.bincount(index, weights=y, minlength=bins)[present]
    return Reliability(confidence=sums / count[present], frequency=hits / count[present], count=count[present])


def expected_calibration_error(conf: NDArray[np.floating], labels: NDArray[Any], bins: int = 10) -> float:
    """The bins' gaps between mean confidence and observed frequency, weighted by their share of detections."""
    if len(conf) == 0:
        return 0.0
    r = reliability(conf, labels, bins)
    return float(np.sum(r.count * np.abs(r.confidence - r.frequency)) / np.sum(r.count))


__all__ = [
    "MIN_BAND",
    "Calibration",
    "Reliability",
    "SizeBand",
    "expected_calibration_error",
    "long_sides",
    "reliability",
    "size_bands",
]
