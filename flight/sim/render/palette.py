"""The renderer's colours: ground materials, clothing (mostly pilgrims' white), skin and hair, vehicles, the sky.

Colours are RGB in 0–255. A material is a base colour and how strongly each texture modulates it.

>>> u = uniforms(7, np.arange(4), np.zeros(4, dtype=np.int64), 4)
>>> len(MATERIALS) == len(Material), clothing_colours(u).shape, bool((u < 1).all() and (u >= 0).all())
(True, (4, 3), True)
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


class Material(IntEnum):
    """What a ground texel is made of."""

    SAND = 0
    PAVING = 1
    ASPHALT = 2
    STONE = 3
    CAMP = 4
    QUEUE = 5
    TENT = 6
    ROOF = 7
    CROSS = 8
    WATER = 9
    GATE = 10
    KERB = 11


@dataclass(frozen=True)
class Look:
    """A material's base colour and texture amplitudes (relative brightness); ``joints_m`` draws a slab grid."""

    rgb: tuple[float, float, float]
    grain: float
    mottle: float
    blotch: float
    joints_m: float = 0.0


MATERIALS: dict[Material, Look] = {
    Material.SAND: Look((192, 166, 128), 0.05, 0.07, 0.08),
    Material.PAVING: Look((176, 170, 158), 0.04, 0.03, 0.04, joints_m=2.0),
    Material.ASPHALT: Look((96, 95, 98), 0.07, 0.04, 0.05),
    Material.STONE: Look((206, 196, 178), 0.03, 0.03, 0.03, joints_m=1.0),
    Material.CAMP: Look((204, 184, 148), 0.05, 0.06, 0.06),
    Material.QUEUE: Look((168, 164, 156), 0.04, 0.03, 0.03, joints_m=1.5),
    Material.TENT: Look((232, 228, 216), 0.01, 0.02, 0.0),
    Material.ROOF: Look((226, 228, 230), 0.01, 0.01, 0.0),
    Material.CROSS: Look((196, 32, 40), 0.01, 0.0, 0.0),
    Material.WATER: Look((62, 104, 134), 0.02, 0.05, 0.0),
    Material.GATE: Look((86, 76, 66), 0.03, 0.02, 0.0),
    Material.KERB: Look((214, 208, 196), 0.03, 0.0, 0.0),
}

ZONE_MATERIAL = {"walkway": Material.PAVING, "plaza": Material.STONE, "camp": Material.CAMP, "queue": Material.QUEUE}

SKY = (198, 214, 232)
HAZE = (206, 204, 198)
SHADE_FACTOR = 0.55
"""How much light an awning's shade or a cast shadow lets through."""

WHITE_SHARE = 0.78
"""Share of pilgrims in white (ihram); the rest wear colours from :data:`_COLOURED`."""
_WHITES = np.array([[240, 240, 236], [232, 230, 222], [246, 244, 240], [224, 222, 214]], dtype=float)
_COLOURED = np.array(
    [[40, 40, 44], [30, 52, 110], [120, 30, 36], [34, 96, 60], [150, 120, 80], [90, 90, 96], [200, 170, 40],
     [70, 40, 90], [180, 90, 40], [60, 110, 150]],
    dtype=float,
)  # fmt: skip
_SKIN = np.array([[92, 64, 44], [124, 88, 62], [62, 44, 32], [150, 112, 84]], dtype=float)
_HAIR = np.array([[28, 24, 22], [46, 38, 32], [236, 234, 228]], dtype=float)  # the last: a white cap
_VEHICLES = np.array([[236, 236, 236], [200, 200, 204], [40, 40, 44], [180, 30, 30], [220, 190, 60]], dtype=float)


def clothing_colours(u: FloatArray) -> FloatArray:
    """Clothing colours from uniform numbers (N×4 in [0, 1)): :data:`WHITE_SHARE` white, the rest coloured, each
    slightly varied."""
    white = u[:, 0] < WHITE_SHARE
    shade = _WHITES[(u[:, 1] * len(_WHITES)).astype(int)]
    out = np.where(white[:, None], shade, _COLOURED[(u[:, 1] * len(_COLOURED)).astype(int)])
    varied: FloatArray = np.clip(out * (0.92 + 0.12 * u[:, 2:3]), 0, 255)
    return varied


def skin_colours(u: FloatArray) -> FloatArray:
    """Skin tones from uniform numbers (N)."""
    skin: FloatArray = _SKIN[(u * len(_SKIN)).astype(int)]
    return skin


def hair_colours(u: FloatArray) -> FloatArray:
    """Hair from above from uniform numbers (N): dark half the time, brown 30 %, a white cap 20 %."""
    return _HAIR[np.searchsorted([0.5, 0.8], u, side="right")]


def vehicle_colours(u: FloatArray) -> FloatArray:
    """Vehicle paint from uniform numbers (N)."""
    paint: FloatArray = _VEHICLES[(u * len(_VEHICLES)).astype(int)]
    return paint


def uniforms(seed: int, rows: NDArray[np.int64], generations: NDArray[np.int64], k: int) -> FloatArray:
    """``k`` numbers in [0, 1) for each (row, generation), fixed by the seed alone (a counter-based hash,
    SplitMix64), so an actor's look does not depend on which others were drawn with it."""
    mask = np.uint64(0xFFFFFFFFFFFFFFFF)
    with np.errstate(over="ignore"):
        key = (np.uint64(seed & 0xFFFFFFFF) << np.uint64(32)) ^ rows.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        key ^= generations.astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
        lanes = key[:, None] + np.arange(1, k + 1, dtype=np.uint64)[None, :] * np.uint64(0x9E3779B97F4A7C15)
        z = lanes & mask
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z ^= z >> np.uint64(31)
    out: FloatArray = (z >> np.uint64(11)).astype(np.float64) / float(2**53)
    return out


__all__ = [
    "HAZE",
    "MATERIALS",
    "SHADE_FACTOR",
    "SKY",
    "WHITE_SHARE",
    "ZONE_MATERIAL",
    "Look",
    "Material",
    "clothing_colours",
    "hair_colours",
    "skin_colours",
    "uniforms",
    "vehicle_colours",
]
