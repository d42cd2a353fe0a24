"""The capsule drawing the shipped detector's training and acceptance renders were made with (the renderer's
code before it measured each box's own pixels instead of a patch of its size group's), kept as the reference its
faster successor must equal pixel for pixel: ``test_raster.py``."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from flight.sim.render.coverage import Coverage
from flight.sim.render.palette import SHADE_FACTOR
from flight.sim.render.raster import BODY, SHADOW, capsule_boxes

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Image = NDArray[np.uint8]
_BUCKETS = np.array([4, 8, 16, 32, 64, 128])


def reference_capsules(
    image: Image,
    a: FloatArray,
    b: FloatArray,
    r: FloatArray,
    rgb: FloatArray,
    mode: int,
    cover: tuple[Coverage, IntArray] | None = None,
) -> None:
    """The capsules as the renderer drew them when the shipped detector's data were made: each size group over a
    patch of its bucket's size from every box's corner, in ascending order of the group's key."""
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
