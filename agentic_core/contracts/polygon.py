"""The one polygon geometry, on a plane (north/east metres): which points lie inside a polygon or a circle, how far
they are from a polygon's edge, and its area. Vectorised over points with NumPy.

The rule, everywhere (mission geofences, the vehicle's fence, scene zones, perception's landmarks): even-odd ray
casting, and a point on an edge or a corner (within :data:`EDGE_TOLERANCE_M`) counts as **inside**; a circle
contains the points at its radius too. So a waypoint placed exactly on a fence line is allowed by an inclusion
fence and refused by an exclusion fence, the same way in the mission validator and on the vehicle.

>>> square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
>>> points_in_polygon(np.array([[5.0, 5.0], [12.0, 5.0], [10.0, 5.0]]), square).tolist()
[True, False, True]
>>> distance_to_edge(np.array([[5.0, 2.0]]), square).tolist(), polygon_area(square)
([2.0], 100.0)
>>> points_in_circle(np.array([[3.0, 4.0], [3.0, 4.1]]), (0.0, 0.0), 5.0).tolist()
[True, False]
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

EDGE_TOLERANCE_M = 1e-6
"""A point this close to an edge is on it (and so inside); far below any position's precision."""


def _points(points: ArrayLike) -> FloatArray:
    return np.asarray(points, dtype=np.float64).reshape(-1, 2)


def _corners(polygon: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """The corners (K×2) and each corner's successor (the polygon rolled by one)."""
    a = _points(polygon)
    return a, np.concatenate((a[1:], a[:1]))


def distance_to_edge(points: ArrayLike, polygon: ArrayLike) -> FloatArray:
    """Distance from N points (N×2) to the nearest edge of a polygon (K×2, corners in order); +inf without
    corners. Inside or out, it is the distance to the boundary."""
    pts = _points(points)
    a, b = _corners(polygon)
    if len(a) == 0:
        return np.full(len(pts), np.inf)
    ab = b - a
    ap = pts[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nkj,kj->nk", ap, ab) / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-24), 0.0, 1.0)
    nearest = a[None, :, :] + t[..., None] * ab[None, :, :]
    d: FloatArray = np.linalg.norm(pts[:, None, :] - nearest, axis=2).min(axis=1)
    return d


def _crossings_odd(pts: FloatArray, a: FloatArray, b: FloatArray) -> BoolArray:
    """The even-odd rule: a ray from each point towards +first axis crosses the edges an odd number of times."""
    x1, y1, x2, y2 = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    sloped = y1 != y2  # a level edge is never crossed
    px, py = pts[:, :1], pts[:, 1:2]
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x_at = x1 + (py - y1) * (x2 - x1) / np.where(sloped, y2 - y1, 1.0)
    crossings = ((y1 > py) != (y2 > py)) & (px < x_at) & sloped
    odd: BoolArray = np.count_nonzero(crossings, axis=1) % 2 == 1
    return odd


def points_in_polygon(points: ArrayLike, polygon: ArrayLike) -> BoolArray:
    """Which of N points (N×2) lie inside a polygon (K×2, corners in order, not repeated): even-odd, with the
    edges inside. A NaN point is outside; fewer than three corners enclose nothing but their edges."""
    pts = _points(points)
    a, b = _corners(polygon)
    if len(a) == 0:
        return np.zeros(len(pts), dtype=bool)
    inside: BoolArray = _crossings_odd(pts, a, b)
    if not inside.all():  # only the points outside by the crossings can still lie on an edge
        rest = ~inside
        inside[rest] = distance_to_edge(pts[rest], a) <= EDGE_TOLERANCE_M
    return inside


def crossing_parity(points: ArrayLike, polygon: ArrayLike) -> BoolArray:
    """The even-odd rule alone, without :func:`points_in_polygon`'s edge test: quicker, for rasterising (a texel
    exactly on an edge may go either way, which no picture shows)."""
    pts = _points(points)
    a, b = _corners(polygon)
    return _crossings_odd(pts, a, b) if len(a) else np.zeros(len(pts), dtype=bool)


def point_in_polygon(point: Sequence[float], polygon: Sequence[Sequence[float]]) -> bool:
    """:func:`points_in_polygon` for one point, in plain Python (the vehicle asks this every tick)."""
    return outside_by(point, polygon) == 0.0


def outside_by(point: Sequence[float], polygon: Sequence[Sequence[float]]) -> float:
    """How far one point lies outside a polygon (corners in order): 0 inside or on an edge, else the distance to
    the nearest edge. The same rule as :func:`points_in_polygon` and :func:`distance_to_edge`, in plain Python:
    for one point and a fence of a few corners it is ten times quicker than numpy's set-up."""
    px, py = float(point[0]), float(point[1])
    if not (math.isfinite(px) and math.isfinite(py)):
        return math.inf
    k = len(polygon)
    if k == 0:
        return math.inf
    odd = False
    nearest = math.inf
    for i in range(k):
        x1, y1 = polygon[i][0], polygon[i][1]
        x2, y2 = polygon[(i + 1) % k][0], polygon[(i + 1) % k][1]
        if (y1 > py) != (y2 > py) and px < x1 + (py - y1) * (x2 - x1) / (y2 - y1):
            odd = not odd
        dx, dy = x2 - x1, y2 - y1
        t = min(1.0, max(0.0, ((px - x1) * dx + (py - y1) * dy) / max(dx * dx + dy * dy, 1e-24)))
        nearest = min(nearest, math.hypot(px - (x1 + t * dx), py - (y1 + t * dy)))
    if odd or nearest <= EDGE_TOLERANCE_M:
        return 0.0
    return nearest


def points_in_circle(points: ArrayLike, centre: Sequence[float], radius: float) -> BoolArray:
    """Which of N points (N×2) lie within ``radius`` of ``centre`` (the circle itself included)."""
    pts = _points(points)
    inside: BoolArray = np.hypot(pts[:, 0] - centre[0], pts[:, 1] - centre[1]) <= radius
    return inside


def polygon_area(polygon: ArrayLike) -> float:
    """The area enclosed by a simple polygon (K×2), by the shoelace formula; 0 for fewer than three corners."""
    a, b = _corners(polygon)
    if len(a) < 3:
        return 0.0
    return 0.5 * abs(float(np.dot(a[:, 0], b[:, 1]) - np.dot(a[:, 1], b[:, 0])))


__all__ = [
    "EDGE_TOLERANCE_M",
    "crossing_parity",
    "distance_to_edge",
    "outside_by",
    "point_in_polygon",
    "points_in_circle",
    "points_in_polygon",
    "polygon_area",
]
