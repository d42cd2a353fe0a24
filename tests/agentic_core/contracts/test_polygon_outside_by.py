"""``outside_by`` (plain Python, one point) agrees with the vectorised ``points_in_polygon`` and
``distance_to_edge`` on random points around random polygons, edges and corners included."""

from __future__ import annotations

import math

import numpy as np

from agentic_core.contracts.polygon import distance_to_edge, outside_by, points_in_polygon


def test_outside_by_agrees_with_the_vectorised_rule() -> None:
    rng = np.random.default_rng(7)
    for _ in range(200):
        k = int(rng.integers(3, 12))
        angles = np.sort(rng.uniform(0, 2 * np.pi, k))
        polygon = np.c_[np.cos(angles), np.sin(angles)] * rng.uniform(10, 500, (k, 1))
        points = rng.uniform(-600, 600, (50, 2))
        points[:5] = polygon[:5] if k >= 5 else points[:5]  # corners are on the boundary: inside
        inside = points_in_polygon(points, polygon)
        gap = distance_to_edge(points, polygon)
        corners = polygon.tolist()
        for point, is_in, d in zip(points.tolist(), inside, gap, strict=True):
            got = outside_by(point, corners)
            assert (got == 0.0) == bool(is_in), (point, got, is_in)
            if not is_in:
                assert math.isclose(got, float(d), rel_tol=1e-9, abs_tol=1e-9)


def test_nan_and_empty_are_outside() -> None:
    square = [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]
    assert outside_by((math.nan, 0.5), square) == math.inf
    assert outside_by((0.5, 0.5), []) == math.inf
    assert outside_by((0.5, 0.5), square) == 0.0 and outside_by((1.0, 0.5), square) == 0.0
    assert math.isclose(outside_by((3.0, 0.5), square), 2.0)
