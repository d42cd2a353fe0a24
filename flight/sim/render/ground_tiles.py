"""The ground's look from a scene's zones and landmarks, rasterised tile by tile (north/east grid, RGB).

:class:`GroundLayers` turns a :class:`~flight.sim.scene_model.Scene` into painting layers, in order: bare sand, the
zones (a walkway's paving, a plaza's stone, a camp's packed sand), polygon landmarks (a road's asphalt with kerbs,
water, camps), point landmarks (tents, a medical post's roof with its red cross, gate pillars, exit markings,
water tanks) and last the shade of awnings. :meth:`GroundLayers.tile` paints one square tile of ``TILE`` texels;
the colour of a texel depends only on the scene and its ground position, so tiles join seamlessly and a frame looks
the same whichever way the aircraft came.

>>> from flight.sim.scene_file import load_scene
>>> layers = GroundLayers(load_scene("scenes/hajj_emergency.yaml"))
>>> tile = layers.tile(0.1, 0, 0)
>>> tile.shape, tile.dtype.name
((256, 256, 3), 'uint8')
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from flight.sim.scene_model import Landmark, Scene, Zone

from .palette import MATERIALS, SHADE_FACTOR, ZONE_MATERIAL, Material
from .texture import SIZE, texture

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]
TILE = 256
"""Texels along a tile's side."""
KERB_M = 0.3
TENT_HALF_M = 2.5
POST_HALF_M = 3.0

_BASE = np.array([MATERIALS[m].rgb for m in Material], dtype=np.float32)
_AMPS = np.array([[MATERIALS[m].grain, MATERIALS[m].mottle, MATERIALS[m].blotch] for m in Material], dtype=np.float32)
_JOINTS = np.array([MATERIALS[m].joints_m for m in Material], dtype=np.float32)


@dataclass(frozen=True)
class Layer:
    """One painted shape: its material (``None``: shade), bounding box (north/east min, max) and membership test."""

    material: Material | None
    lo: tuple[float, float]
    hi: tuple[float, float]
    contains: Callable[[FloatArray], BoolArray]
    kerb: FloatArray | None = None


class GroundLayers:
    """The painting layers of a scene, and the tiles they make."""

    def __init__(self, scene: Scene) -> None:
        self.layers: list[Layer] = []
        for zone in scene.zones:
            self._zone(zone)
        for lm in scene.landmarks:
            if lm.polygon is not None and lm.kind != "shade":
                self._polygon_landmark(lm)
        for lm in scene.landmarks:
            if lm.position is not None:
                self._point_landmark(lm, scene.seed)
        for lm in scene.landmarks:
            if lm.kind == "shade":
                self._shade(lm)
        offset = np.random.default_rng([scene.seed, 31]).integers(0, SIZE, 2)
        self._offset = (int(offset[0]), int(offset[1]))

    def tile(self, res_m: float, ti: int, tj: int) -> NDArray[np.uint8]:
        """Tile (``ti``, ``tj``) at ``res_m`` metres per texel: rows go north, columns east, from the tile's
        south-west corner at (``ti``, ``tj``) × ``TILE`` × ``res_m``; RGB texels (``TILE``×``TILE``×3)."""
        rows = ti * TILE + np.arange(TILE)
        cols = tj * TILE + np.arange(TILE)
        north = (rows + 0.5) * res_m
        east = (cols + 0.5) * res_m
        lo = (float(north[0]), float(east[0]))
        hi = (float(north[-1]), float(east[-1]))
        material = np.zeros((TILE, TILE), dtype=np.intp)
        shade = np.zeros((TILE, TILE), dtype=bool)
        points: FloatArray | None = None
        for layer in self.layers:
            if layer.lo[0] > hi[0] or layer.hi[0] < lo[0] or layer.lo[1] > hi[1] or layer.hi[1] < lo[1]:
                continue
            if points is None:
                grid_n, grid_e = np.meshgrid(north, east, indexing="ij")
                points = np.column_stack([grid_n.ravel(), grid_e.ravel()])
            inside = layer.contains(points).reshape(TILE, TILE)
            if layer.material is None:
                shade |= inside
                continue
            material[inside] = layer.material
            if layer.kerb is not None:
                near = inside.ravel().copy()
                near[near] = _near_edge(points[near], layer.kerb, KERB_M)
                material[near.reshape(TILE, TILE)] = Material.KERB
        r = (rows[:, None] + self._offset[0]) % SIZE
        c = (cols[None, :] + self._offset[1]) % SIZE
        amps = _AMPS[material]
        lum = 1.0 + amps[..., 0] * texture("grain")[r, c] + amps[..., 1] * texture("mottle")[r, c]
        lum += amps[..., 2] * texture("blotch")[r // 4, c // 4]
        joints = _JOINTS[material]
        if joints.any():
            with np.errstate(divide="ignore", invalid="ignore"):
                jn = np.mod(north[:, None], joints) < 0.08
                je = np.mod(east[None, :], joints) < 0.08
            lum = np.where((joints > 0) & (jn | je), lum * 0.86, lum)
        lum = np.where(shade, lum * SHADE_FACTOR, lum)
        rgb: NDArray[np.uint8] = np.clip(_BASE[material] * lum[..., None], 0.0, 255.0).astype(np.uint8)
        return rgb

    def _add(self, material: Material | None, vertices: FloatArray, kerb: bool = False) -> None:
        lo, hi = vertices.min(axis=0), vertices.max(axis=0)
        self.layers.append(
            Layer(
                material,
                (float(lo[0]), float(lo[1])),
                (float(hi[0]), float(hi[1])),
                functools.partial(_inside, vertices=vertices),
                vertices if kerb else None,
            )
        )

    def _disc(self, material: Material, centre: tuple[float, float], radius: float) -> None:
        cn, ce = centre
        self.layers.append(
            Layer(
                material,
                (cn - radius, ce - radius),
                (cn + radius, ce + radius),
                lambda p: np.hypot(p[:, 0] - cn, p[:, 1] - ce) <= radius,
            )
        )

    def _zone(self, zone: Zone) -> None:
        material = ZONE_MATERIAL.get(zone.kind, Material.PAVING)
        if zone.circle is not None and zone.polygon is None:
            c = zone.circle.center
            self._disc(material, (c.north, c.east), zone.circle.radius_m)
        elif zone.polygon is not None:
            self._add(material, zone.vertices())

    def _polygon_landmark(self, lm: Landmark) -> None:
        vertices = np.array([[p.north, p.east] for p in lm.polygon or []], dtype=float)
        kind = lm.kind
        if kind == "road":
            self._add(Material.ASPHALT, vertices, kerb=True)
        elif kind == "water":
            self._add(Material.WATER, vertices)
        elif kind in ("camp", "tent"):
            self._add(Material.CAMP if kind == "camp" else Material.TENT, vertices)
        elif kind == "medical_post":
            self._add(Material.ROOF, vertices)
        else:
            self._add(Material.STONE, vertices)

    def _point_landmark(self, lm: Landmark, seed: int) -> None:
        c = lm.center
        centre = np.array([c.north, c.east])
        turn = (hash_unit(seed, c.north, c.east) - 0.5) * math.pi / 3.0
        if lm.kind == "tent":
            self._add(Material.TENT, _square(centre, TENT_HALF_M, TENT_HALF_M, turn))
            self._add(Material.KERB, _square(centre, TENT_HALF_M, 0.08, turn))  # the ridge
        elif lm.kind == "medical_post":
            self._add(Material.ROOF, _square(centre, POST_HALF_M, POST_HALF_M, 0.0))
            self._add(Material.CROSS, _square(centre, 2.0, 0.6, 0.0))
            self._add(Material.CROSS, _square(centre, 0.6, 2.0, 0.0))
        elif lm.kind == "water":
            self._disc(Material.WATER, (c.north, c.east), 1.5)
        elif lm.kind == "gate":
            for side in (-3.0, 3.0):
                self._add(Material.GATE, _square(centre + np.array([0.0, side]), 0.6, 0.6, 0.0))
        elif lm.kind == "exit":
            self._add(Material.KERB, _square(centre, 0.4, 3.0, 0.0))
        elif lm.kind == "shade":
            self.layers.append(
                Layer(None, (c.north - 4.0, c.east - 4.0), (c.north + 4.0, c.east + 4.0), _square_test(centre, 4.0))
            )

    def _shade(self, lm: Landmark) -> None:
        if lm.polygon is not None:
            self._add(None, np.array([[p.north, p.east] for p in lm.polygon], dtype=float))


def hash_unit(seed: int, north: float, east: float) -> float:
    """A number in [0, 1) fixed by a seed and a place (so a landmark's look does not depend on draw order)."""
    key = (seed * 1_000_003 + round(north * 10) * 7_919 + round(east * 10) * 104_729) % (2**32)
    return float(np.random.default_rng(key).random())


def _inside(points: FloatArray, vertices: FloatArray) -> BoolArray:
    """Even-odd ray casting, edge by edge (a texel exactly on an edge may fall either side: it does not matter)."""
    px, py = points[:, 0], points[:, 1]
    odd = np.zeros(len(points), dtype=bool)
    for (x1, y1), (x2, y2) in zip(vertices, np.roll(vertices, -1, axis=0), strict=True):
        if y1 == y2:
            continue
        crosses = (y1 > py) != (y2 > py)
        odd ^= crosses & (px < x1 + (py - y1) * ((x2 - x1) / (y2 - y1)))
    return odd


def _near_edge(points: FloatArray, vertices: FloatArray, within: float) -> BoolArray:
    """Which points lie within ``within`` metres of the polygon's boundary."""
    near = np.zeros(len(points), dtype=bool)
    for a, b in zip(vertices, np.roll(vertices, -1, axis=0), strict=True):
        ab = b - a
        t = np.clip(((points - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        gap = points - (a + t[:, None] * ab)
        near |= gap[:, 0] ** 2 + gap[:, 1] ** 2 < within * within
    return near


def _square(centre: FloatArray, half_n: float, half_e: float, turn: float) -> FloatArray:
    c, s = math.cos(turn), math.sin(turn)
    corners = np.array([[-half_n, -half_e], [half_n, -half_e], [half_n, half_e], [-half_n, half_e]])
    rotated: FloatArray = corners @ np.array([[c, s], [-s, c]]) + centre
    return rotated


def _square_test(centre: FloatArray, half: float) -> Callable[[FloatArray], BoolArray]:
    def inside(p: FloatArray) -> BoolArray:
        out: BoolArray = (np.abs(p[:, 0] - centre[0]) <= half) & (np.abs(p[:, 1] - centre[1]) <= half)
        return out

    return inside


__all__ = ["TILE", "GroundLayers", "Layer", "hash_unit"]
