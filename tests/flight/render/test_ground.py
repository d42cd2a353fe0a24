"""The ground's tiles: membership of a tile's texels in a zone is the contracts' even-odd rule, also where the
shortcut (no edge crosses the tile: all in or all out) applies, and around a concave notch whose corners lie
outside the tile; a tile's look depends only on its place."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.contracts.camera import CameraPose, CameraSpec
from agentic_core.contracts.polygon import crossing_parity
from flight.sim.render.ground import GroundMap
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


def test_a_reused_view_table_is_never_stale() -> None:
    """The straight-down texel offsets are kept for the last spec, attitude and height: after each change of one of
    them the view is the one a table made anew gives (the same map otherwise, since a frame's texels are counted
    from the mosaic in use); and two maps with other specs, used in turn, keep their own."""
    scene = load_scene("scenes/hajj_emergency.yaml")
    wide, small = CameraSpec(width_px=640, height_px=480), CameraSpec(width_px=320, height_px=240, hfov_deg=70.0)
    tilted = CameraSpec(width_px=640, height_px=480, gimbal_pitch_deg=-80.0)
    views = [
        (wide, CameraPose(north_m=150.0, east_m=10.0, down_m=-30.0)),
        (wide, CameraPose(north_m=151.5, east_m=9.0, down_m=-30.0)),  # moved, same attitude: the table serves
        (wide, CameraPose(north_m=151.5, east_m=9.0, down_m=-30.0, yaw_rad=0.3)),
        (wide, CameraPose(north_m=151.5, east_m=9.0, down_m=-31.0, yaw_rad=0.3)),
        (small, CameraPose(north_m=151.5, east_m=9.0, down_m=-31.0, yaw_rad=0.3)),
        (tilted, CameraPose(north_m=150.0, east_m=10.0, down_m=-30.0)),
        (wide, CameraPose(north_m=150.0, east_m=10.0, down_m=-30.0)),
    ]
    kept, anew = GroundMap(scene), GroundMap(scene)
    theirs, theirs_anew = GroundMap(scene), GroundMap(scene)
    for k, (spec, pose) in enumerate(views):
        anew._offset_key = theirs_anew._offset_key = None
        assert np.array_equal(kept.view(spec, pose), anew.view(spec, pose)), k
        other = small if spec is not small else wide
        assert np.array_equal(theirs.view(other, pose), theirs_anew.view(other, pose)), k
    assert not np.array_equal(kept.view(*views[0]), kept.view(*views[2]))
