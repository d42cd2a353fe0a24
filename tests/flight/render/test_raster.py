"""Capsules are drawn pixel for pixel as the shipped detector's renders drew them (``capsules_reference``), also
where it is hardest to: crowds of overlapping capsules in many size groups (a pixel several groups cover blends
them in the groups' order), one capsule over another in the same group (the later shows), capsules larger than the
largest group, half out of the image, of no length, of a radius under a pixel; and the pixels each covers at
least half go to the same owners."""

from __future__ import annotations

import numpy as np
import pytest

from flight.sim.render.coverage import Coverage
from flight.sim.render.raster import BODY, FLAT, SHADOW, draw_capsules

from .capsules_reference import reference_capsules


def _capsules(seed: int, count: int, width: int, height: int, scale: float) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    a = rng.uniform([-20.0, -20.0], [width + 20.0, height + 20.0], (count, 2))
    b = a + rng.normal(0.0, scale, (count, 2)) * (rng.random((count, 1)) < 0.8)  # a fifth are discs
    r = rng.choice([0.1, 0.4, 1.0, 2.5, 6.0, 15.0, 70.0], count, p=[0.05, 0.1, 0.3, 0.3, 0.15, 0.07, 0.03])
    rgb = rng.uniform(0.0, 300.0, (count, 3))  # over 255 too: a colour is not clipped before blending
    return a, b, r, rgb


@pytest.mark.parametrize("mode", [BODY, FLAT, SHADOW])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_capsules_are_drawn_as_the_reference_draws_them(mode: int, seed: int) -> None:
    width, height = 97, 61
    a, b, r, rgb = _capsules(seed, 300, width, height, scale=8.0)
    start = np.random.default_rng(seed + 10).integers(0, 256, (height, width, 3), dtype=np.uint8)
    owners = np.random.default_rng(seed + 20).integers(0, 40, len(a))
    mine, theirs = start.copy(), start.copy()
    cover_mine, cover_theirs = Coverage(width, height), Coverage(width, height)
    draw_capsules(mine, a, b, r, rgb, mode, (cover_mine, owners))
    reference_capsules(theirs, a, b, r, rgb, mode, (cover_theirs, owners))
    assert not np.array_equal(mine, start)  # something was drawn
    assert np.array_equal(mine, theirs)
    assert np.array_equal(cover_mine.owner, cover_theirs.owner)
    assert np.array_equal(cover_mine.shown_share(40), cover_theirs.shown_share(40))


def test_pixels_covered_by_several_size_groups_blend_in_the_groups_order() -> None:
    """Three discs of three sizes stacked on one spot, given largest first: the smallest group is drawn first, so
    the largest shows on top; and two discs of one group on one spot: the later one shows, not a mix."""
    image = np.zeros((40, 40, 3), dtype=np.uint8)
    centre = np.array([[20.0, 20.0]] * 3)
    rgb = np.array([[250.0, 0.0, 0.0], [0.0, 250.0, 0.0], [0.0, 0.0, 250.0]])
    theirs = image.copy()
    draw_capsules(image, centre, centre, np.array([12.0, 5.0, 1.2]), rgb, FLAT)
    reference_capsules(theirs, centre, centre, np.array([12.0, 5.0, 1.2]), rgb, FLAT)
    assert np.array_equal(image, theirs)
    assert image[20, 20].tolist() == [250, 0, 0]
    same = np.zeros((40, 40, 3), dtype=np.uint8)
    draw_capsules(same, centre[:2], centre[:2], np.array([5.0, 5.0]), rgb[:2], FLAT)
    assert same[20, 20].tolist() == [0, 250, 0]


def test_a_crowd_drawn_as_the_renderer_draws_one() -> None:
    """Hundreds of small overlapping capsules, as a crowd from 30 m gives, over a real-sized frame."""
    width, height = 640, 480
    rng = np.random.default_rng(7)
    a = rng.uniform(0.0, [width, height], (800, 2))
    b = a + rng.normal(0.0, 4.0, (800, 2))
    r = rng.uniform(1.5, 4.5, 800)
    rgb = rng.uniform(150.0, 255.0, (800, 3))
    mine = np.full((height, width, 3), 120, dtype=np.uint8)
    theirs = mine.copy()
    for mode in (SHADOW, BODY, FLAT):
        draw_capsules(mine, a, b, r, rgb, mode)
        reference_capsules(theirs, a, b, r, rgb, mode)
        assert np.array_equal(mine, theirs)


def test_nothing_in_the_image_draws_nothing_and_a_strided_image_is_refused() -> None:
    image = np.full((10, 10, 3), 7, dtype=np.uint8)
    draw_capsules(image, np.array([[-50.0, -50.0]]), np.array([[-40.0, -40.0]]), np.array([2.0]), np.ones((1, 3)), FLAT)
    draw_capsules(image, np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros((0, 3)), FLAT)
    assert (image == 7).all()
    with pytest.raises(ValueError, match="C-contiguous"):
        draw_capsules(
            image[:, ::2], np.array([[2.0, 2.0]]), np.array([[3.0, 3.0]]), np.array([1.0]), np.ones((1, 3)), FLAT
        )


@pytest.mark.parametrize("slope", [0.0, 1e-10, 1e-8, 1e-5, 1e-2, 1.0, 1e3, np.inf])
def test_level_steep_and_tiny_capsules_lose_no_pixel_of_their_rim(slope: float) -> None:
    """The columns worth testing are bounded row by row from the capsule's axis; capsules at every sub-pixel
    offset, exactly level, all but level, steep, vertical, from a dot to a long bar, with radii around the sizes
    where the reach changes form, touch exactly the pixels the reference touches."""
    rng = np.random.default_rng(11)
    count = 400
    a = rng.uniform(5.0, 55.0, (count, 2))
    length = rng.choice([0.0, 1e-4, 0.5, 3.0, 17.0], count)
    step = np.array([1.0, 0.0]) if slope == 0.0 else np.array([0.0, 1.0]) if np.isinf(slope) else np.array([1.0, slope])
    b = a + length[:, None] * step / np.hypot(*step)
    r = rng.choice([0.05, 0.24, 0.25, 0.26, 0.5, 0.99, 1.0, 1.01, 2.5, 7.3], count)
    rgb = rng.uniform(0.0, 255.0, (count, 3))
    for mode in (BODY, SHADOW):
        mine = np.random.default_rng(3).integers(0, 256, (60, 60, 3), dtype=np.uint8)
        theirs = mine.copy()
        cover_mine, cover_theirs = Coverage(60, 60), Coverage(60, 60)
        owners = np.arange(count)
        draw_capsules(mine, a, b, r, rgb, mode, (cover_mine, owners))
        reference_capsules(theirs, a, b, r, rgb, mode, (cover_theirs, owners))
        assert np.array_equal(mine, theirs)
        assert np.array_equal(cover_mine.shown_share(count), cover_theirs.shown_share(count))
