"""The renderer's colours: ground materials, clothing (mostly pilgrims' white), skin and hair, vehicles, the sky.

Colours are RGB in 0–255. A material is a base colour and how strongly each texture modulates it.

>>> len(MATERIALS) == len(Material), clothing_colours(np.random.default_rng(0), 4).shape
(True, (4, 3))
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


def clothing_colours(rng: np.random.Generator, n: int) -> FloatArray:
    """``n`` clothing colours: :data:`WHITE_SHARE` white, the rest coloured, each slightly varied."""
    white = rng.random(n) < WHITE_SHARE
    out = np.where(white[:, None], _WHITES[rng.integers(0, len(_WHITES), n)], _COLOURED[rng.integers(0, 10, n)])
    varied: FloatArray = np.clip(out * rng.uniform(0.92, 1.04, (n, 1)), 0, 255)
    return varied


def skin_colours(rng: np.random.Generator, n: int) -> FloatArray:
    return _SKIN[rng.integers(0, len(_SKIN), n)]


def hair_colours(rng: np.random.Generator, n: int) -> FloatArray:
    return _HAIR[rng.choice(len(_HAIR), n, p=[0.5, 0.3, 0.2])]


def vehicle_colours(rng: np.random.Generator, n: int) -> FloatArray:
    return _VEHICLES[rng.integers(0, len(_VEHICLES), n)]


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
    "vehicle_colours",
]
