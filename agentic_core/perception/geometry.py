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
    """Which of N points (N×2) lie inside a polygon (K×2, corners in order), by the even-odd rule."""
    inside = np.zeros(len(points), dtype=bool)
    px, py = points[:, 0], points[:, 1]
    for (x1, y1), (x2, y2) in zip(polygon, np.roll(polygon, -1, axis=0), strict=True):
        if y1 == y2:
            continue
        crosses = (y1 > py) != (y2 > py)
        x_at = x1 + (py - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (px < x_at)
    return inside


def distance_to_polygon_edge(points: FloatArray, polygon: FloatArray) -> FloatArray:
    """Distance (m) from N points to the nearest edge of a polygon (K×2)."""
    a, b = polygon, np.roll(polygon, -1, axis=0)
    ab = b - a
    ap = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nkj,kj->nk", ap, ab) / np.maximum(np.einsum("kj,kj->k", ab, ab), 1e-12), 0.0, 1.0)
    nearest = a[None, :, :] + t[..., None] * ab[None, :, :]
    d: FloatArray = np.linalg.norm(points[:, None, :] - nearest, axis=2).min(axis=1)
    return d
