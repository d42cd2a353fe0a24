"""Calibration: the fitted map is monotone, lowers the expected calibration error of a miscalibrated detector on
held-out data, and refuses maps that are not probabilities."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from agentic_core.perception.calibration import Calibration, expected_calibration_error, reliability


def overconfident(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Scores whose real hit rate is score²: a detector that claims more than it delivers."""
    rng = np.random.default_rng(seed)
    scores = rng.uniform(0.2, 1.0, n)
    return scores, (rng.uniform(size=n) < scores**2).astype(int)


def test_fit_lowers_the_calibration_error_on_held_out_data() -> None:
    scores, labels = overconfident(1, 4000)
    held_scores, held_labels = overconfident(2, 4000)
    raw = expected_calibration_error(held_scores, held_labels)
    cal = Calibration.fit(scores, labels)
    fitted = expected_calibration_error(cal.apply(held_scores), held_labels)
    assert raw > 0.1 and fitted < 0.03 and fitted < raw / 4


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 1), st.booleans()), min_size=1, max_size=60))
def test_fitted_map_is_monotone_and_in_range(pairs) -> None:
    scores = np.array([s for s, _ in pairs])
    labels = np.array([int(b) for _, b in pairs])
    cal = Calibration.fit(scores, labels)
    out = cal.apply(np.linspace(-0.5, 1.5, 101))
    assert np.all(np.diff(out) >= -1e-12) and np.all((out >= 0) & (out <= 1))
    assert Calibration.model_validate_json(cal.model_dump_json()) == cal


def by_size(seed: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Scores whose hit rate depends on the box's size too: score² for boxes under 20 px, √score from 20 px."""
    rng = np.random.default_rng(seed)
    scores, long_px = rng.uniform(0.2, 1.0, n), rng.choice([8.0, 40.0], n)
    rate = np.where(long_px < 20.0, scores**2, np.sqrt(scores))
    return scores, (rng.uniform(size=n) < rate).astype(int), long_px


def test_a_map_per_size_band_is_calibrated_in_each_band_where_one_map_is_not() -> None:
    scores, labels, long_px = by_size(4, 8000)
    held_scores, held_labels, held_long = by_size(5, 8000)
    one = Calibration.fit(scores, labels)
    sized = Calibration.fit(scores, labels, long_px, size_edges_px=[20.0])
    assert sized.size_edges_px == [20.0] and len(sized.by_size) == 2
    for small in (True, False):
        band = (held_long < 20.0) == small
        flat = expected_calibration_error(one.apply(held_scores[band]), held_labels[band])
        banded = expected_calibration_error(sized.apply(held_scores[band], held_long[band]), held_labels[band])
        assert flat > 0.1 and banded < 0.03  # one map is off by a tenth in each band
    assert np.array_equal(sized.apply(held_scores), one.apply(held_scores))  # without sizes: the map of all sizes
    assert Calibration.model_validate_json(sized.model_dump_json()) == sized


def test_a_size_band_with_too_few_detections_takes_the_map_of_all_sizes() -> None:
    scores, labels, long_px = by_size(6, 1000)
    long_px[:10] = 100.0  # ten large boxes only
    cal = Calibration.fit(scores, labels, long_px, size_edges_px=[20.0, 50.0], min_band=50)
    assert (cal.by_size[2].scores, cal.by_size[2].probs) == (cal.scores, cal.probs)
    assert cal.by_size[0].scores != cal.scores


def test_reliability_bins_count_everything() -> None:
    scores, labels = overconfident(3, 1000)
    r = reliability(scores, labels, bins=10)
    assert int(r.count.sum()) == 1000 and np.all((r.confidence >= 0) & (r.confidence <= 1))
    assert expected_calibration_error(np.zeros(0), np.zeros(0)) == 0.0


@pytest.mark.parametrize(
    "fields",
    [
        {"scores": [0.0, 0.5], "probs": [0.5, 0.4]},
        {"scores": [0.5, 0.5], "probs": [0.1, 0.2]},
        {"scores": [0.0, 1.0], "probs": [0.0, 1.5]},
        {"scores": [0.0, 1.0], "probs": [0.5]},
        {"scores": [], "probs": []},
        {"scores": [0.0, 1.0], "probs": [0.0, 1.0], "size_edges_px": [10.0], "by_size": []},
        {
            "scores": [0.0, 1.0],
            "probs": [0.0, 1.0],
            "size_edges_px": [20.0, 10.0],
            "by_size": [{"scores": [0.0], "probs": [0.5]}] * 3,
        },
        {
            "scores": [0.0, 1.0],
            "probs": [0.0, 1.0],
            "size_edges_px": [10.0],
            "by_size": [{"scores": [0.0], "probs": [0.5]}, {"scores": [0.0, 1.0], "probs": [0.9, 0.1]}],
        },
    ],
)
def test_maps_that_are_not_probabilities_are_refused(fields) -> None:
    with pytest.raises(ValidationError, match=r"calibration|at least 1"):
        Calibration.model_validate(fields)


def test_fit_on_nothing_is_refused() -> None:
    with pytest.raises(ValueError, match="no scores"):
        Calibration.fit(np.zeros(0), np.zeros(0, int))
