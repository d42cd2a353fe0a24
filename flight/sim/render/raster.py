"""Soft-edged shapes drawn into an RGB image, vectorised in numpy: capsules (discs are capsules of no length) and
convex quadrilaterals.

Capsules are grouped by the size of their pixel box (4, 8, 16, … 128 px a side, each way) and each group is
drawn in one set of array operations; a capsule's edge is anti-aliased over one pixel. ``mode`` says how a
capsule colours what it covers: ``BODY`` paints its colour shaded towards the rim (a rounded body), ``FLAT``
paints it evenly, ``SHADOW`` darkens what is there by :data:`~flight.sim.render.palette.SHADE_FACTOR`.

>>> image = np.zeros((20, 20, 3), dtype=np.uint8)
>>> draw_capsules(image, np.array([[5.0, 10.0]]), np.array([[15.0, 10.0]]), np.array([3.0]),
...               np.array([[255.0, 255.0, 255.0]]), FLAT)
>>> int(image[10, 10, 0]), int(image[2, 10, 0])
(255, 0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .coverage import Coverage
from .palette import SHADE_FACTOR

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Image = NDArray[np.uint8]

BODY, FLAT, SHADOW = 0, 1, 2
_BUCKETS = np.array([4, 8, 16, 32, 64, 128])


def capsule_boxes(a: FloatArray, b: FloatArray, r: FloatArray) -> FloatArray:
    """The pixel extent (K×4: x0, y0, x1, y1) of K capsules from ``a`` to ``b`` (K×2 pixels) of radius ``r``."""
    lo = np.minimum(a, b) - r[:, None]
    hi = np.maximum(a, b) + r[:, None]
    box: FloatArray = np.column_stack([lo, hi])
    return box


def draw_capsules(
    image: Image,
    a: FloatArray,
    b: FloatArray,
    r: FloatArray,
    rgb: FloatArray,
    mode: int,
    cover: tuple[Coverage, IntArray] | None = None,
) -> None:
    """Draw K capsules into ``image`` (H×W×3, in place), all in one ``mode``; where capsules of one size group
    overlap, the later one shows. With ``cover`` (a :class:`Coverage` and each capsule's owner), the pixels each
    capsule covers at least half are handed to its owner in the same order."""
    if len(a) == 0:
        return
    if not image.flags.c_contiguous:
        raise ValueError("draw_capsules draws into a C-contiguous image only (it writes through a flat view)")
    height, width = image.shape[:2]
    box = capsule_boxes(a, b, r)
    x0 = np.clip(np.floor(box[:, 0] - 0.5), 0, width).astype(np.int64)
    y0 = np.clip(np.floor(box[:, 1] - 0.5), 0, height).astype(np.int64)
    x1 = np.clip(np.ceil(box[:, 2] + 0.5), 0, width).astype(np.int64)
    y1 = np.clip(np.ceil(box[:, 3] + 0.5), 0, height).astype(np.int64)
    live = np.flatnonzero((x1 > x0) & (y1 > y0))
    if len(live) == 0:
        return
    bw = np.searchsorted(_BUCKETS, x1[live] - x0[live])
    bh = np.searchsorted(_BUCKETS, y1[live] - y0[live])
    key = bw * 16 + bh
    shape = _Shapes(a, b, r, rgb, mode, x0, y0, x1, y1, cover)
    for k in np.unique(key):
        members = live[key == k]
        i, j = divmod(int(k), 16)
        if i < len(_BUCKETS) and j < len(_BUCKETS):
            _draw_group(image, members, int(_BUCKETS[i]), int(_BUCKETS[j]), shape)
        else:  # very near the camera: one at a time, over its own box
            for m in members:
                _draw_group(image, np.array([m]), int(x1[m] - x0[m]), int(y1[m] - y0[m]), shape)


class _Shapes:
    """The capsules of one :func:`draw_capsules` call and their clipped pixel boxes."""

    def __init__(
        self,
        a: FloatArray,
        b: FloatArray,
        r: FloatArray,
        rgb: FloatArray,
        mode: int,
        x0: IntArray,
        y0: IntArray,
        x1: IntArray,
        y1: IntArray,
        cover: tuple[Coverage, IntArray] | None = None,
    ) -> None:
        f = np.float32
        self.cover = cover
        self.a, self.ab, self.r = a.astype(f), (b - a).astype(f), r.astype(f)
        self.rgb, self.mode = rgb.astype(f), mode
        self.x0, self.y0, self.x1, self.y1 = x0, y0, x1, y1


def _draw_group(image: Image, k: IntArray, w: int, h: int, s: _Shapes) -> None:
    """Draw the capsules ``k`` over patches of ``w``×``h`` pixels from their boxes' corners. Works on squared
    distances: the edge's coverage is ``(r² - d²) / 2r + ½``, first order in ``r - d``, with no square root."""
    f = np.float32
    px = (s.x0[k, None, None] + np.arange(w)[None, None, :]).astype(f) + f(0.5)
    py = (s.y0[k, None, None] + np.arange(h)[None, :, None]).astype(f) + f(0.5)
    rx = px - s.a[k, 0, None, None]
    ry = py - s.a[k, 1, None, None]
    abx, aby = s.ab[k, 0, None, None], s.ab[k, 1, None, None]
    length2 = np.maximum(abx * abx + aby * aby, f(1e-9))
    t = rx * (abx / length2) + ry * (aby / length2)
    np.clip(t, f(0.0), f(1.0), out=t)
    qx = rx - t * abx
    qy = ry - t * aby
    qx *= qx
    qy *= qy
    qx += qy
    reach = s.r[k] * s.r[k] + np.maximum(s.r[k], f(0.25))  # d² below this: some coverage
    which, yy, xx = np.nonzero(qx < reach[:, None, None])
    kk = k[which]
    ys = s.y0[kk] + yy
    xs = s.x0[kk] + xx
    keep = (ys < s.y1[kk]) & (xs < s.x1[kk])
    if not keep.all():
        which, yy, xx, kk, ys, xs = which[keep], yy[keep], xx[keep], kk[keep], ys[keep], xs[keep]
    if len(which) == 0:
        return
    d2 = qx[which, yy, xx]
    r = s.r[kk]
    al = np.clip((r * r + f(1e-6) - d2) * (f(0.5) / np.maximum(r, f(0.25))) + f(0.5), f(0.0), f(1.0))[:, None]
    flat = image.reshape(-1, 3)
    at = ys * image.shape[1] + xs
    under = np.take(flat, at, axis=0).astype(f)
    if s.mode == SHADOW:
        colour = under * f(SHADE_FACTOR)
    elif s.mode == BODY:
        rim2 = np.minimum(d2 / np.maximum(r * r, f(1e-6)), f(1.0))
        colour = s.rgb[kk] * (f(1.0) - f(0.35) * rim2)[:, None]
    else:
        colour = s.rgb[kk]
    flat[at] = (under + (colour - under) * al).astype(np.uint8)
    if s.cover is not None:
        solid = al[:, 0] >= f(0.5)
        s.cover[0].paint(at[solid], s.cover[1][kk[solid]])


def draw_quads(image: Image, corners: FloatArray, rgb: FloatArray) -> None:
    """Fill Q convex quadrilaterals (Q×4×2 pixel corners, in order around each) with flat colours (Q×3)."""
    height, width = image.shape[:2]
    for quad, colour in zip(corners, rgb, strict=True):
        if np.isnan(quad).any():
            continue
        x0, y0 = (max(int(np.floor(v)), 0) for v in quad.min(axis=0))
        x1, y1 = min(int(np.ceil(quad[:, 0].max())), width), min(int(np.ceil(quad[:, 1].max())), height)
        if x1 <= x0 or y1 <= y0:
            continue
        px = np.arange(x0, x1)[None, :] + 0.5
        py = np.arange(y0, y1)[:, None] + 0.5
        sides = []
        for i in range(4):
            (ax, ay), (bx, by) = quad[i], quad[(i + 1) % 4]
            sides.append((bx - ax) * (py - ay) - (by - ay) * (px - ax))
        stack = np.stack(sides)
        inside = (stack >= 0).all(axis=0) | (stack <= 0).all(axis=0)
        image[y0:y1, x0:x1][inside] = np.asarray(colour, dtype=np.float64).clip(0, 255).astype(np.uint8)


__all__ = ["BODY", "FLAT", "SHADOW", "capsule_boxes", "draw_capsules", "draw_quads"]
