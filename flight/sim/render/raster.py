"""Soft-edged shapes drawn into an RGB image, vectorised in numpy: capsules (discs are capsules of no length) and
convex quadrilaterals.

Capsules are grouped by the size of their pixel box (4, 8, 16, … 128 px a side, each way; the grouping fixes
how overlapping capsules mix: a group's capsules all blend with what was there before the group). The pixels of
every box of one call are measured in one set of array operations over the boxes themselves, then blended group
after group, every pixel's first group at once, then its next; a capsule's edge is anti-aliased over one pixel.
``mode`` says how a capsule colours what it covers: ``BODY`` paints its colour shaded towards the rim (a rounded
body), ``FLAT`` paints it evenly, ``SHADOW`` darkens what is there by
:data:`~flight.sim.render.palette.SHADE_FACTOR`.

>>> image = np.zeros((20, 20, 3), dtype=np.uint8)
>>> draw_capsules(image, np.array([[5.0, 10.0]]), np.array([[15.0, 10.0]]), np.array([3.0]),
...               np.array([[255.0, 255.0, 255.0]]), FLAT)
>>> int(image[10, 10, 0]), int(image[2, 10, 0])
(255, 0)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .coverage import Coverage
from .palette import SHADE_FACTOR

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Image = NDArray[np.uint8]
F32 = NDArray[np.float32]
Pixels = NDArray[np.void]

BODY, FLAT, SHADOW = 0, 1, 2
_BUCKETS = np.array([4, 8, 16, 32, 64, 128])
_PIXEL = np.dtype((np.void, 3))
"""An RGB pixel as one item, so a pixel is read and written as one element."""


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
    order, group = _drawing_order(x1[live] - x0[live], y1[live] - y0[live])
    k = live[order]
    hits = _Hits(a[k], b[k], r[k], x0[k], y0[k], x1[k], y1[k], width)
    if len(hits.at) == 0:
        return
    paint = None if mode == SHADOW else _Paint.of(rgb[k], hits.member, hits.shade() if mode == BODY else None)
    _blend_in_order(image.reshape(-1, 3).view(_PIXEL).reshape(-1), hits, group[hits.member], paint)
    if cover is not None:
        solid = hits.alpha >= np.float32(0.5)
        cover[0].paint(hits.at[solid], cover[1][k[hits.member[solid]]])


def _drawing_order(w: IntArray, h: IntArray) -> tuple[IntArray, NDArray[np.int32]]:
    """The capsules (of pixel boxes ``w``×``h``) in drawing order and each one's group: grouped by the size of their
    box (4, 8, … 128 px a side, each way; the smaller sizes first), in their given order within a group, and alone
    when larger than the largest size. A group's capsules all blend with what was there before the group."""
    bw = np.searchsorted(_BUCKETS, w)
    bh = np.searchsorted(_BUCKETS, h)
    key = bw * 16 + bh
    order = np.argsort(key, kind="stable")
    key = key[order]
    new = np.ones(len(key), dtype=bool)
    new[1:] = (key[1:] != key[:-1]) | (bw[order][1:] >= len(_BUCKETS)) | (bh[order][1:] >= len(_BUCKETS))
    group = (np.cumsum(new) - 1).astype(np.int32)
    return order, group


class _Hits:
    """Every pixel of the capsules' boxes (in drawing order, each box row by row) that a capsule covers at all: its
    flat index, its capsule (``member``), its squared distance to the capsule's axis and its coverage. Works on
    squared distances: the edge's coverage is ``(r² - d²) / 2r + ½``, first order in ``r - d``, with no square
    root."""

    def __init__(
        self,
        a: FloatArray,
        b: FloatArray,
        r: FloatArray,
        x0: IntArray,
        y0: IntArray,
        x1: IntArray,
        y1: IntArray,
        width: int,
    ) -> None:
        f = np.float32
        row_member, row_y, start, stop = _row_spans(a, b, r, x0, y0, x1, y1)
        n = stop - start
        row = np.repeat(np.arange(len(n)), n)
        member = row_member[row]
        xs = np.arange(int(n.sum())) + np.repeat(start - (np.cumsum(n) - n), n)
        af, ab, rf = a.astype(f), (b - a).astype(f), r.astype(f)
        abx, aby = ab[:, 0], ab[:, 1]
        length2 = np.maximum(abx * abx + aby * aby, f(1e-9))
        ry = row_y.astype(f) + f(0.5)  # what depends on the row alone, once a row
        ry -= af[:, 1].copy()[row_member]
        rx = xs.astype(f) + f(0.5)
        rx -= af[:, 0].copy()[member]  # a column of its own: gathering from it is a plain copy
        t = rx * (abx / length2)[member]
        t += (ry * (aby / length2)[row_member])[row]
        np.clip(t, f(0.0), f(1.0), out=t)
        qx = rx - t * abx[member]
        qy = ry[row] - t * aby[member]
        qx *= qx
        qy *= qy
        qx += qy
        reach = rf * rf + np.maximum(rf, f(0.25))  # d² below this: some coverage
        sel = np.flatnonzero(qx < reach[member])
        self.member = member[sel]
        self.at = (row_y * width)[row[sel]] + xs[sel]
        self.d2 = qx[sel]
        self.r = rf
        m = self.member
        al = (rf * rf + f(1e-6))[m] - self.d2
        al *= (f(0.5) / np.maximum(rf, f(0.25)))[m]
        al += f(0.5)
        np.clip(al, f(0.0), f(1.0), out=al)
        self.alpha = al

    def shade(self) -> F32:
        """Each hit's share of its capsule's colour on a rounded body: darker towards the rim."""
        f = np.float32
        rim2 = self.d2 / np.maximum(self.r * self.r, f(1e-6))[self.member]
        np.minimum(rim2, f(1.0), out=rim2)
        shade: F32 = f(1.0) - f(0.35) * rim2
        return shade


@dataclass(frozen=True)
class _Paint:
    """What colours the hits: each capsule's colour, one channel an array (so a hit's channel is read as one
    number), each hit's capsule, and on a rounded body each hit's shade."""

    channels: tuple[F32, F32, F32]
    member: IntArray
    shade: F32 | None

    @classmethod
    def of(cls, rgb: FloatArray, member: IntArray, shade: F32 | None) -> _Paint:
        f = np.float32
        return cls((rgb[:, 0].astype(f), rgb[:, 1].astype(f), rgb[:, 2].astype(f)), member, shade)

    def part(self, which: NDArray[np.bool_]) -> _Paint:
        return _Paint(self.channels, self.member[which], None if self.shade is None else self.shade[which])

    def channel(self, c: int) -> F32:
        """Channel ``c`` of each hit's colour (a new array)."""
        colour: F32 = self.channels[c][self.member]
        if self.shade is not None:
            colour *= self.shade
        return colour


def _row_spans(
    a: FloatArray, b: FloatArray, r: FloatArray, x0: IntArray, y0: IntArray, x1: IntArray, y1: IntArray
) -> tuple[IntArray, IntArray, IntArray, IntArray]:
    """Every row of every capsule's box (its capsule, its y) and, within the box, the columns from ``start`` to
    ``stop`` that the capsule can touch: a pixel whose centre is within the reach of the capsule's axis lies within
    that reach of an axis point both across and along the row, so only the columns beside the part of the axis
    within reach of the row's centre line can be touched. The bound is widened so that the exact test, in float32,
    never meets a pixel outside it."""
    h = y1 - y0
    row_member = np.repeat(np.arange(len(h)), h)
    row_y = y0[row_member] + (np.arange(int(h.sum())) - np.repeat(np.cumsum(h) - h, h))
    reach = np.sqrt(r * r + np.maximum(r, 0.25)) * 1.001 + 0.01
    ax, ay, dx, dy, grow = (v[row_member] for v in (a[:, 0], a[:, 1], b[:, 0] - a[:, 0], b[:, 1] - a[:, 1], reach))
    centre = row_y + 0.5
    level = np.abs(dy) < 1e-9
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(level, 0.0, (centre - grow - ay) / dy)
        t1 = np.where(level, 1.0, (centre + grow - ay) / dy)
    lo, hi = np.clip(np.minimum(t0, t1), 0.0, 1.0), np.clip(np.maximum(t0, t1), 0.0, 1.0)
    near = ~level | (np.abs(ay - centre) <= grow)
    xa, xb = ax + lo * dx, ax + hi * dx
    first = np.ceil(np.minimum(xa, xb) - grow - 0.5)
    last = np.floor(np.maximum(xa, xb) + grow - 0.5) + 1.0
    start = np.clip(first, x0[row_member], x1[row_member]).astype(np.int64)
    stop = np.clip(last, start, x1[row_member]).astype(np.int64)
    stop[~near] = start[~near]
    return row_member, row_y, start, stop


def _blend_in_order(pixels: Pixels, hits: _Hits, group: NDArray[np.int32], paint: _Paint | None) -> None:
    """Blend the hits group after group (``group`` never decreases along them): each group over what the ones before
    it drew. A pixel's value depends on its own hits alone, so every pixel's first group is blended at once, then
    every pixel's next one, and so on (a crowd's pixels see few groups each); what is left of one group, at once."""
    at, alpha = hits.at, hits.alpha
    first = np.empty(len(pixels), dtype=np.int32)
    while len(group) and group[0] != group[-1]:
        first[at[::-1]] = group[::-1]  # numpy keeps the last write: each pixel's earliest group
        now = first[at] == group
        _blend(pixels, at[now], alpha[now], None if paint is None else paint.part(now))
        later = ~now
        at, alpha, group = at[later], alpha[later], group[later]
        paint = None if paint is None else paint.part(later)
    if len(at):
        _blend(pixels, at, alpha, paint)


def _blend(pixels: Pixels, at: IntArray, alpha: F32, paint: _Paint | None) -> None:
    """Pixels ``at`` (of ``pixels``, an image seen as one 3-byte item per pixel) moved towards their ``paint`` by
    ``alpha`` (darkened by the shade factor when ``paint`` is None); where ``at`` repeats, the last entry shows."""
    under = np.take(pixels, at).view(np.uint8).reshape(-1, 3).astype(np.float32)
    mixed = np.empty_like(under)
    for c in range(3):  # channel by channel: a hit's alpha and colour are then one number each
        below = under[:, c]
        colour = below * np.float32(SHADE_FACTOR) if paint is None else paint.channel(c)
        colour -= below
        colour *= alpha
        colour += below
        mixed[:, c] = colour
    np.put(pixels, at, mixed.astype(np.uint8).view(_PIXEL).reshape(-1))


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
