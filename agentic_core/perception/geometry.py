"""Plane geometry on north/east points: inside a polygon, distance to its edge (vectorised over points).

>>> square = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]])
>>> points_in_polygon(np.array([[5.0, 5.0], [12.0, 5.0]]), square).tolist()
[True, False]
>>> distance_to_polygon_edge(np.array([[5.0, 2.0]]), square).tolist()
[2.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def points_in_polygon(points: FloatArray, polygon: FloatArray) -> NDArray[np.bool_]:
    """Which of N points (N×2) lie inside a polygon (K×2, corners in order), by the even-odd rule (every edge at
    once: N×K crossings)."""
    x1, y1 = polygon[:, 0], polygon[:, 1]
    nxt = _next_corners(polygon)
    x2, y2 = nxt[:, 0], nxt[:, 1]
    sloped = y1 != y2  # a level edge is never crossed
    px, py = points[:, :1], points[:, 1:2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = x1 + (py - y1) * (x2 - x1) / np.where(sloped, y2 - y1, 1.0)
    crossings = ((y1 > py) != (y2 > py)) & (px < x_at) & sloped
    inside: NDArray[np.bool_] = np.count_nonzero(crossings, axis=1) % 2 == 1
    return inside


def _next_corners(polygon: FloatArray) -> FloatArray:
    """Each corner's successor (the polygon rolled by one), without ``np.roll``'s general machinery."""
    return np.concatenate((polygon[1:], polygon[:1]))


def distance_to_polygon_edge(points: FloatArray, polygon: FloatArray) -> FloatArray:
    """Distance (m) from N points to the nearest edge of a polygon (K×2)."""
    a, b = polygon, _next_corners(polygon)
    ab = b - a
    ap = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nkj,kj->nk", ap, ab) / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-12), 0.0, 1.0)
    nearest = a[None, :, :] + t[..., None] * ab[None, :, :]
    d: FloatArray = np.linalg.norm(points[:, None, :] - nearest, axis=2).min(axis=1)
    return d
