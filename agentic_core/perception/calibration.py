"""Calibrated confidence: a monotone map from a detector's raw score to the probability that a detection is a real
person, fitted on renders (isotonic regression, :func:`scipy.optimize.isotonic_regression`), and the measures of
how well a confidence is calibrated (expected calibration error, the reliability diagram's bins).

The World Model's ``conf`` is the calibrated value: a track at 0.8 is a person four times in five.

>>> import numpy as np
>>> cal = Calibration.fit(np.array([0.1, 0.2, 0.3, 0.6, 0.7, 0.9]), np.array([0, 0, 1, 0, 1, 1]))
>>> cal.apply(np.array([0.1, 0.65, 0.95])).round(2).tolist()
[0.0, 0.75, 1.0]
>>> Calibration.model_validate(cal.model_dump()) == cal
True
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


class Calibration(BaseModel):
    """A non-decreasing piecewise-linear map from raw score to probability: ``scores`` are its knots (increasing),
    ``probs`` the values there (non-decreasing, 0–1); below the first knot the first value, above the last the last."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    method: str = "isotonic"
    scores: list[float] = Field(min_length=1)
    probs: list[float] = Field(min_length=1)

    @model_validator(mode="after")
    def _monotone(self) -> Calibration:
        s, p = np.asarray(self.scores), np.asarray(self.probs)
        if len(s) != len(p):
            raise ValueError(f"calibration: {len(s)} scores but {len(p)} probabilities")
        if not (np.all(np.diff(s) > 0) and np.all(np.diff(p) >= 0) and np.all((p >= 0) & (p <= 1))):
            raise ValueError("calibration: scores must increase and probabilities be non-decreasing in 0-1")
        return self

    @classmethod
    def identity(cls) -> Calibration:
        """The map that leaves scores as they are."""
        return cls(method="identity", scores=[0.0, 1.0], probs=[0.0, 1.0])

    @classmethod
    def fit(cls, scores: NDArray[np.floating], labels: NDArray[Any]) -> Calibration:
        """Isotonic regression of ``labels`` (1: a true person) on ``scores``, with tied scores pooled first."""
        from scipy.optimize import isotonic_regression

        if len(scores) == 0:
            raise ValueError("calibration: no scores to fit")
        knots, inverse = np.unique(np.asarray(scores, dtype=np.float64), return_inverse=True)
        counts = np.bincount(inverse).astype(np.float64)
        means = np.bincount(inverse, weights=np.asarray(labels, dtype=np.float64)) / counts
        fitted = np.clip(isotonic_regression(means, weights=counts).x, 0.0, 1.0)
        keep = np.r_[True, np.diff(fitted) > 0] | np.r_[np.diff(fitted) > 0, True]
        return cls(scores=knots[keep].tolist(), probs=np.maximum.accumulate(fitted[keep]).tolist())

    def apply(self, scores: NDArray[np.floating]) -> FloatArray:
        """The calibrated probability of each raw score."""
        return np.interp(np.asarray(scores, dtype=np.float64), self.scores, self.probs)


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


__all__ = ["Calibration", "Reliability", "expected_calibration_error", "reliability"]
