"""The ground's tiles: membership of a tile's texels in a zone is the contracts' even-odd rule, also where the
shortcut (no edge crosses the tile: all in or all out) applies, and around a concave notch whose corners lie
outside the tile; a tile's look depends only on its place."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.contracts.polygon import crossing_parity
from flight.sim.render.ground_tiles import TILE, GroundLayers, _in_polygon
from flight.sim.scene_file import load_scene

# A U: a 100 m square with a 10 m-wide notch cut from its north edge down to its middle.
U_SHAPE = np.array([[0, 0], [100, 0], [100, 45], [50, 45], [50, 55], [100, 55], [100, 100], [0, 100]], dtype=float)


def _grid(north0: float, east0: float, res: float = 0.1) -> np.ndarray:
    north = north0 + (np.arange(TILE) + 0.5) * res
    east = east0 + (np.arange(TILE) + 0.5) * res
    n, e = np.meshgrid(north, east, indexing="ij")
    return np.column_stack([n.ravel(), e.ravel()])


@pytest.mark.parametrize(
    "corner",
    [(10.0, 10.0), (60.0, 40.0), (60.0, 48.0), (95.0, 95.0), (-40.0, -40.0), (200.0, 10.0), (45.0, 44.0)],
    ids=["inside", "across-notch-edge", "notch-only-edges", "across-corner", "outside", "far", "notch-tip"],
)
def test_tile_membership_is_the_even_odd_rule(corner: tuple[float, float]) -> None:
    points = _grid(*corner)
    assert np.array_equal(_in_polygon(points, U_SHAPE), crossing_parity(points, U_SHAPE))


def test_a_notch_through_a_tile_without_its_corners_is_not_missed() -> None:
    points = _grid(60.0, 43.0, res=0.02)  # a 5 m tile across the notch's side, no vertex of it in the tile
    inside = _in_polygon(points, U_SHAPE)
    assert inside.any() and not inside.all()


def test_a_tile_looks_the_same_whenever_it_is_made() -> None:
    scene = load_scene("scenes/hajj_emergency.yaml")
    first, again = GroundLayers(scene), GroundLayers(scene)
    a = first.tile(0.1, 5, -1)
    first.tile(0.1, 0, 0)
    assert np.array_equal(a, again.tile(0.1, 5, -1)) and np.array_equal(a, first.tile(0.1, 5, -1))
    assert a.reshape(-1, 3).std(axis=0).min() > 3  # textured, and the road's kerb is in it
