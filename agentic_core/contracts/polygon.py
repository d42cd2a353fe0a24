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


class Ring:
    """A polygon's corners (K×2, in order, not repeated) with its edges worked out once: for asking the same
    polygon about points again and again (a scene zone every step, a landmark every frame), where the set-up is
    most of the cost. The module's functions take a ``Ring`` wherever they take corners.

    >>> ring = Ring([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
    >>> ring.contains(np.array([[5.0, 5.0], [12.0, 5.0]])).tolist(), ring.distance(np.array([[5.0, 2.0]])).tolist()
    ([True, False], [2.0])
    """

    __slots__ = ("_ab", "_ab2", "_den", "_dx", "_sloped", "_x1", "_y1", "_y2", "a", "b")

    def __init__(self, polygon: ArrayLike) -> None:
        a = _points(polygon).copy()
        b = np.concatenate((a[1:], a[:1]))
        a.flags.writeable = False
        b.flags.writeable = False
        self.a, self.b = a, b  # the corners and each corner's successor
        self._ab = b - a
        self._ab2 = np.maximum(np.einsum("kj,kj->k", self._ab, self._ab), 1e-24)
        self._x1, self._y1, self._y2 = a[:, 0], a[:, 1], b[:, 1]
        self._dx = b[:, 0] - a[:, 0]
        self._sloped = self._y1 != self._y2  # a level edge is never crossed
        self._den = np.where(self._sloped, self._y2 - self._y1, 1.0)

    def __len__(self) -> int:
        return len(self.a)

    def parity(self, points: ArrayLike) -> BoolArray:
        """The even-odd rule alone: a ray from each point towards +first axis crosses the edges an odd number of
        times (what :func:`crossing_parity` answers)."""
        pts = _points(points)
        if len(self.a) == 0:
            return np.zeros(len(pts), dtype=bool)
        px, py = pts[:, :1], pts[:, 1:2]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            x_at = self._x1 + (py - self._y1) * self._dx / self._den
        crossings = ((self._y1 > py) != (self._y2 > py)) & (px < x_at) & self._sloped
        odd: BoolArray = np.logical_xor.reduce(crossings, axis=1)
        return odd

    def contains(self, points: ArrayLike) -> BoolArray:
        """Which points lie inside (what :func:`points_in_polygon` answers)."""
        pts = _points(points)
        inside = self.parity(pts)
        if len(self.a) and not inside.all():  # only the points outside by the crossings can still lie on an edge
            rest = ~inside
            inside[rest] = self.distance(pts[rest]) <= EDGE_TOLERANCE_M
        return inside

    def contains_and_distance(self, points: ArrayLike) -> tuple[BoolArray, FloatArray]:
        """:meth:`contains` and :meth:`distance` of the same points in one pass (the crowd asks both of its
        walkers near an edge)."""
        pts = _points(points)
        if len(self.a) == 0:
            return np.zeros(len(pts), dtype=bool), np.full(len(pts), np.inf)
        gap = self.distance(pts)
        inside: BoolArray = self.parity(pts) | (gap <= EDGE_TOLERANCE_M)
        return inside, gap

    def outside_by(self, points: ArrayLike) -> FloatArray:
        """How far each point lies outside: 0 inside or on an edge, else the distance to the nearest edge (what
        :func:`outside_by` answers for one point). One pass for what :meth:`contains` then :meth:`distance` of the
        points outside would compute twice."""
        pts = _points(points)
        if len(self.a) == 0:
            return np.full(len(pts), np.inf)
        rest = ~self.parity(pts)
        gap = self.distance(pts[rest])
        out = np.zeros(len(pts))
        out[rest] = np.where(gap <= EDGE_TOLERANCE_M, 0.0, gap)
        return out

    def distance(self, points: ArrayLike) -> FloatArray:
        """Distance from each point to the nearest edge, inside or out (what :func:`distance_to_edge` answers)."""
        pts = _points(points)
        if len(self.a) == 0:
            return np.full(len(pts), np.inf)
        a, ab = self.a, self._ab
        ap = pts[:, None, :] - a[None, :, :]
        t = np.clip((ap[..., 0] * ab[:, 0] + ap[..., 1] * ab[:, 1]) / self._ab2, 0.0, 1.0)
        gap = pts[:, None, :] - (a[None, :, :] + t[..., None] * ab[None, :, :])
        gap *= gap
        d: FloatArray = np.sqrt(gap[..., 0] + gap[..., 1]).min(axis=1)
        return d


def _ring(polygon: ArrayLike | Ring) -> Ring:
    return polygon if isinstance(polygon, Ring) else Ring(polygon)


def distance_to_edge(points: ArrayLike, polygon: ArrayLike | Ring) -> FloatArray:
    """Distance from N points (N×2) to the nearest edge of a polygon (K×2, corners in order); +inf without
    corners. Inside or out, it is the distance to the boundary."""
    return _ring(polygon).distance(points)


def points_in_polygon(points: ArrayLike, polygon: ArrayLike | Ring) -> BoolArray:
    """Which of N points (N×2) lie inside a polygon (K×2, corners in order, not repeated): even-odd, with the
    edges inside. A NaN point is outside; fewer than three corners enclose nothing but their edges."""
    return _ring(polygon).contains(points)


def crossing_parity(points: ArrayLike, polygon: ArrayLike | Ring) -> BoolArray:
    """The even-odd rule alone, without :func:`points_in_polygon`'s edge test: quicker, for rasterising (a texel
    exactly on an edge may go either way, which no picture shows)."""
    return _ring(polygon).parity(points)


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


def polygon_area(polygon: ArrayLike | Ring) -> float:
    """The area enclosed by a simple polygon (K×2), by the shoelace formula; 0 for fewer than three corners."""
    ring = _ring(polygon)
    a, b = ring.a, ring.b
    if len(a) < 3:
        return 0.0
    return 0.5 * abs(float(np.dot(a[:, 0], b[:, 1]) - np.dot(a[:, 1], b[:, 0])))


__all__ = [
    "EDGE_TOLERANCE_M",
    "Ring",
    "crossing_parity",
    "distance_to_edge",
    "outside_by",
    "point_in_polygon",
    "points_in_circle",
    "points_in_polygon",
    "polygon_area",
]
