"""The ground straight down over a scene: north up and where the scene says (a pond in the north-east shows blue
there and not at its mirror places), a scene without zones is plain sand, the picture is the same every time,
an enormous scene is drawn coarser rather than enormous, and the PNG reads back exactly."""

from __future__ import annotations

import io
import time
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from flight.sim.render.orthophoto import MARGIN_M, MAX_PX, Orthophoto, render_orthophoto
from flight.sim.render.png import png_bytes
from flight.sim.scene_file import load_scene
from flight.sim.scene_model import Scene

POND = (120.0, 60.0)  # its centre, north and east of home: off every axis, so a flip or a swap misses it


def scene_with(tmp_path: Path, landmarks: str) -> Scene:
    path = tmp_path / "scene.yaml"
    path.write_text(
        "id: t\nseed: 3\nhome: {lat_deg: 21.4133, lon_deg: 39.8933, alt_msl_m: 300.0}\n" + landmarks, encoding="utf-8"
    )
    return load_scene(path)


def pond(tmp_path: Path) -> Scene:
    n, e = POND
    corners = ", ".join(
        f"{{north: {n + dn}, east: {e + de}}}" for dn, de in ((-15, -15), (15, -15), (15, 15), (-15, 15))
    )
    far_corner = "".join(  # two gates, so that the picture spans the pond's mirror places
        f"  - {{id: G{i}, kind: gate, position: {{north: {-n}, east: {east}}}}}\n" for i, east in enumerate((-e, n))
    )
    return scene_with(tmp_path, f"landmarks:\n  - {{id: P, kind: water, polygon: [{corners}]}}\n{far_corner}")


def pixel(photo: Orthophoto, north: float, east: float) -> np.ndarray:
    """The picture's pixel over a ground point, found from the extent alone (rows go south from the north edge)."""
    ext = photo.extent
    row, col = int((ext.north_m - north) / ext.m_per_px), int((east - ext.west_m) / ext.m_per_px)
    rgb: np.ndarray = photo.image[row, col].astype(int)
    return rgb


def blue(rgb: np.ndarray) -> bool:
    return bool(rgb[2] > rgb[0] + 30)


def test_a_pond_is_drawn_where_the_scene_puts_it_and_north_is_up(tmp_path: Path) -> None:
    photo = render_orthophoto(pond(tmp_path), m_per_px=0.5)
    n, e = POND
    assert blue(pixel(photo, n, e)) and blue(pixel(photo, n + 12, e + 12)) and blue(pixel(photo, n - 12, e - 12))
    for mirror in ((-n, e), (n, -e), (-n, -e), (e, n), (n + 20, e), (n, e - 20)):
        assert not blue(pixel(photo, *mirror)), mirror
    ext = photo.extent
    assert ext.north_m >= n + 15 + MARGIN_M - ext.m_per_px and ext.east_m >= e + 15 + MARGIN_M - ext.m_per_px
    assert ext.south_m <= -MARGIN_M and ext.west_m <= -MARGIN_M  # home is in it, with the margin


def sand(rgb: np.ndarray) -> bool:
    """Sand's colour family: its base colour's red to blue (the textures scale all three alike)."""
    return bool(abs(rgb[0] / max(rgb[2], 1) - 192 / 128) < 0.06)


def test_under_each_drawn_landmark_of_a_real_scene_is_not_sand() -> None:
    scene = load_scene("scenes/hajj_emergency.yaml")
    photo = render_orthophoto(scene, m_per_px=0.5)
    kinds = ("tent", "medical_post", "water", "exit")  # and polygons; a shade only darkens what is under it
    drawn = [m for m in scene.landmarks if (m.polygon and m.kind != "shade") or m.kind in kinds]
    assert drawn and not any(sand(pixel(photo, m.center.north, m.center.east)) for m in drawn)
    assert sand(pixel(photo, photo.extent.south_m + 1, photo.extent.west_m + 1))  # the margin's corner is


def test_no_zones_is_plain_sand_around_home_and_the_same_every_time(tmp_path: Path) -> None:
    bare = scene_with(tmp_path, "")
    photo, again = render_orthophoto(bare, m_per_px=0.5), render_orthophoto(bare, m_per_px=0.5)
    assert np.array_equal(photo.image, again.image)
    assert photo.image.shape[:2] == (photo.extent.rows, photo.extent.cols)
    assert abs(photo.extent.rows * 0.5 - 2 * MARGIN_M) <= 1.0 and abs(photo.extent.cols * 0.5 - 2 * MARGIN_M) <= 1.0
    r, g, b = (photo.image[..., i].astype(int) for i in range(3))
    assert bool((r > b).all() and (g > b).all())  # sand everywhere: warm, never blue or grey
    assert photo.image.reshape(-1, 3).std(axis=0).min() > 1  # textured, not a flat fill


def test_an_enormous_scene_is_drawn_coarser_not_enormous(tmp_path: Path) -> None:
    far = scene_with(tmp_path, "landmarks:\n  - {id: F, kind: gate, position: {north: 90000, east: -70000}}\n")
    started = time.perf_counter()
    photo = render_orthophoto(far, m_per_px=0.1)
    took = time.perf_counter() - started
    assert max(photo.image.shape[:2]) <= MAX_PX and photo.m_per_px > 40  # 160 km on 2048 pixels
    assert photo.extent.north_m >= 90000 - photo.m_per_px and photo.extent.west_m <= -70000
    assert took < 10.0


@pytest.mark.parametrize("m_per_px", [0.0, -1.0, float("nan"), float("inf")])
def test_a_bad_resolution_is_a_clear_error(tmp_path: Path, m_per_px: float) -> None:
    with pytest.raises(ValueError, match="m_per_px"):
        render_orthophoto(scene_with(tmp_path, ""), m_per_px=m_per_px)


def test_the_png_reads_back_pixel_for_pixel(tmp_path: Path) -> None:
    photo = render_orthophoto(pond(tmp_path), m_per_px=1.0)
    back = matplotlib.image.imread(io.BytesIO(png_bytes(photo.image)), format="png")
    assert np.array_equal((back * 255).round().astype(np.uint8), photo.image)
    with pytest.raises(ValueError, match="H×W×3 uint8"):
        png_bytes(photo.image[..., :2])
