"""The scene's ground seen straight down over the whole scene: one RGB picture with its bounds in north/east metres,
the console's basemap. The ground only (no people), painted by :class:`~.ground_tiles.GroundLayers`, so a texel
here has the colour the camera sees there; the same scene always gives the same picture.

>>> from flight.sim.scene_file import load_scene
>>> photo = render_orthophoto(load_scene("scenes/hajj_emergency.yaml"), m_per_px=2.0)
>>> photo.image.shape[2], photo.image.dtype.name, photo.m_per_px >= 2.0
(3, 'uint8', True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from flight.sim.scene_model import Scene

from .ground_tiles import TILE, GroundLayers

MARGIN_M = 20.0
"""Ground shown beyond the scene's outermost zone, landmark or home."""
MAX_PX = 2048
"""Pixels along the picture's longer side at most: a scene too large for the resolution asked is drawn coarser."""


@dataclass(frozen=True)
class Extent:
    """The ground a picture covers: its south-west corner in metres from home, its size in pixels and the
    metres per pixel (rows go south from the north edge, columns east)."""

    south_m: float
    west_m: float
    rows: int
    cols: int
    m_per_px: float

    @property
    def north_m(self) -> float:
        """The picture's north edge, metres north of home."""
        return self.south_m + self.rows * self.m_per_px

    @property
    def east_m(self) -> float:
        """The picture's east edge, metres east of home."""
        return self.west_m + self.cols * self.m_per_px


@dataclass(frozen=True)
class Orthophoto:
    """A picture of the ground (rows × cols × 3, uint8, north up) and the ground it covers."""

    image: NDArray[np.uint8]
    extent: Extent

    @property
    def m_per_px(self) -> float:
        """Metres of ground per pixel."""
        return self.extent.m_per_px


def orthophoto_extent(scene: Scene, m_per_px: float = 0.5, margin_m: float = MARGIN_M, max_px: int = MAX_PX) -> Extent:
    """The ground a picture of ``scene`` covers: every zone, landmark and home with ``margin_m`` around, at
    ``m_per_px`` or coarser so that no side passes ``max_px``; edges on whole pixels of a grid fixed at home."""
    if not (m_per_px > 0.0 and math.isfinite(m_per_px)) or max_px < 1 or not math.isfinite(margin_m):
        raise ValueError(f"orthophoto: m_per_px {m_per_px} > 0, max_px {max_px} >= 1, a finite margin")
    points = [(0.0, 0.0)]
    for zone in scene.zones:
        points += [(float(n), float(e)) for n, e in zone.vertices()]
    for mark in scene.landmarks:
        points.append((mark.center.north, mark.center.east))
        points += [(p.north, p.east) for p in mark.polygon or []]
    spots = np.array(points, dtype=float)
    lo, hi = spots.min(axis=0) - max(margin_m, 0.0), spots.max(axis=0) + max(margin_m, 0.0)
    span = float((hi - lo).max())
    res = max(m_per_px, span / (max_px - 1)) if max_px > 1 else max(m_per_px, span)
    r0, c0 = math.floor(lo[0] / res), math.floor(lo[1] / res)
    rows = min(max_px, math.ceil(hi[0] / res) - r0)
    cols = min(max_px, math.ceil(hi[1] / res) - c0)
    return Extent(r0 * res, c0 * res, max(rows, 1), max(cols, 1), res)


def render_orthophoto(
    scene: Scene, m_per_px: float = 0.5, margin_m: float = MARGIN_M, max_px: int = MAX_PX
) -> Orthophoto:
    """The ground of ``scene`` straight down over :func:`orthophoto_extent`, north up."""
    extent = orthophoto_extent(scene, m_per_px, margin_m, max_px)
    res = extent.m_per_px
    r0, c0 = round(extent.south_m / res), round(extent.west_m / res)
    t0, t1 = r0 // TILE, (r0 + extent.rows - 1) // TILE
    u0, u1 = c0 // TILE, (c0 + extent.cols - 1) // TILE
    layers = GroundLayers(scene)
    mosaic = np.empty(((t1 - t0 + 1) * TILE, (u1 - u0 + 1) * TILE, 3), dtype=np.uint8)
    for i in range(t0, t1 + 1):
        for j in range(u0, u1 + 1):
            row, col = (i - t0) * TILE, (j - u0) * TILE
            mosaic[row : row + TILE, col : col + TILE] = layers.tile(res, i, j)
    top, left = r0 - t0 * TILE, c0 - u0 * TILE
    south_up = mosaic[top : top + extent.rows, left : left + extent.cols]
    image: NDArray[np.uint8] = np.ascontiguousarray(south_up[::-1])
    return Orthophoto(image, extent)


__all__ = ["MARGIN_M", "MAX_PX", "Extent", "Orthophoto", "orthophoto_extent", "render_orthophoto"]
