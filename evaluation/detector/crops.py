"""Training samples for the person detector, in numpy: square crops of rendered frames (half around a person, half
anywhere), turned by one of the eight symmetries of the square (a camera looking down has no up), and the
centre-point targets of each crop at the network's stride.

A person seen less than :data:`~flight.sim.render.dataset.MIN_SEEN` (mostly covered by others, or mostly out of
the image) is no target; the cells around their centre are left out of the loss (weight 0), so the network is
neither taught to find nor to miss someone it can hardly see.

>>> import numpy as np
>>> t = targets(np.array([[10.0, 6.0, 18.0, 10.0], [0.0, 0.0, 8.0, 8.0]]), np.array([1.0, 0.2]), size=32, stride=4)
>>> t.heat.shape, float(t.heat[2, 3]), int(t.mask.sum()), [round(float(v), 3) for v in t.reg[:, 2, 3]]
((8, 8), 1.0, 1, [0.5, 0.0, 0.693, 0.0])
>>> float(t.weight[1, 1]), float(t.weight[5, 5]), [float(v) for v in t.box[:, 2, 3]]
(0.0, 1.0, [10.0, 6.0, 18.0, 10.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from flight.sim.render.dataset import MIN_SEEN

FloatArray = NDArray[np.float32]
U8 = NDArray[np.uint8]


@dataclass(frozen=True)
class Targets:
    """One crop's targets on the stride grid: the score target (a Gaussian bump per person, 1 at their centre
    cell), the loss weight of each cell (0 around ignored persons), the regression targets and the box (crop
    pixels) at the centre cells, and the mask of those cells."""

    heat: FloatArray
    weight: FloatArray
    reg: FloatArray
    box: FloatArray
    mask: NDArray[np.uint8]


def sample_crops(
    image: U8, boxes: FloatArray, visible: FloatArray, rng: np.random.Generator, *, size: int = 160, count: int = 4
) -> list[tuple[U8, FloatArray, FloatArray]]:
    """``count`` crops of ``size`` pixels with the boxes whose centre falls inside (in crop pixels, unclipped) and
    their visible shares."""
    height, width = image.shape[:2]
    out: list[tuple[U8, FloatArray, FloatArray]] = []
    centres = (boxes[:, :2] + boxes[:, 2:]) / 2.0 if len(boxes) else np.zeros((0, 2), np.float32)
    for k in range(count):
        if len(boxes) and k % 2 == 0:
            cx, cy = centres[rng.integers(len(boxes))]
            x0 = int(np.clip(cx - rng.uniform(0.15, 0.85) * size, 0, width - size))
            y0 = int(np.clip(cy - rng.uniform(0.15, 0.85) * size, 0, height - size))
        else:
            x0, y0 = int(rng.integers(0, width - size + 1)), int(rng.integers(0, height - size + 1))
        inside = (
            (centres[:, 0] >= x0) & (centres[:, 0] < x0 + size) & (centres[:, 1] >= y0) & (centres[:, 1] < y0 + size)
        )
        shifted = boxes[inside] - np.array([x0, y0, x0, y0], np.float32)
        out.append((image[y0 : y0 + size, x0 : x0 + size], shifted.astype(np.float32), visible[inside]))
    return out


def turn(crop: U8, boxes: FloatArray, which: int) -> tuple[U8, FloatArray]:
    """One of the square's eight symmetries (``which`` 0–7: bit 0 flips left-right, bit 1 up-down, bit 2
    swaps the axes), applied to a square crop and its boxes."""
    size = crop.shape[0]
    b = boxes.copy()
    if which & 1:
        crop = crop[:, ::-1]
        b[:, [0, 2]] = size - boxes[:, [2, 0]]
    if which & 2:
        crop = crop[::-1]
        b[:, [1, 3]] = size - b[:, [3, 1]]
    if which & 4:
        crop = crop.transpose(1, 0, 2)
        b = b[:, [1, 0, 3, 2]]
    return np.ascontiguousarray(crop), b


BUMP_REACH = math.sqrt(2.0 * math.log(1e7))
"""A bump is drawn out to this many sigmas, where it falls under 1e-7 (float32 has no more to give next to 1)."""


def _heat(grid: int, gx: NDArray[np.intp], gy: NDArray[np.intp], sigma: FloatArray) -> FloatArray:
    """The score target: per cell the highest of the persons' Gaussian bumps, each drawn in a window out to
    :data:`BUMP_REACH` sigmas (persons of one reach at a time), so a crowded crop costs a few array operations."""
    heat = np.zeros(grid * grid, np.float32)
    reach = np.ceil(BUMP_REACH * sigma).astype(np.intp)
    for r in np.unique(reach).tolist():
        of = reach == r
        d = np.arange(-r, r + 1)
        ys = gy[of, None, None] + d[None, :, None]
        xs = gx[of, None, None] + d[None, None, :]
        two_s2 = (2.0 * sigma[of] * sigma[of]).astype(np.float32)[:, None, None]
        bump = np.exp(-((d[None, None, :] ** 2 + d[None, :, None] ** 2).astype(np.float32)) / two_s2)
        inside = (ys >= 0) & (ys < grid) & (xs >= 0) & (xs < grid)
        np.maximum.at(heat, (ys * grid + xs)[inside], bump[inside])
    return heat.reshape(grid, grid)


def _last_of_each(cells: NDArray[np.intp]) -> NDArray[np.intp]:
    """Indices into ``cells`` of the last occurrence of each cell (what a loop of assignments would leave)."""
    _, first_from_end = np.unique(cells[::-1], return_index=True)
    return len(cells) - 1 - first_from_end


def targets(
    boxes: FloatArray, visible: FloatArray, *, size: int, stride: int, neighbour_boxes: bool = False
) -> Targets:
    """The :class:`Targets` of a square crop's boxes; those seen less than :data:`MIN_SEEN` are ignored.

    With ``neighbour_boxes`` the box is also taught at the two cells next to the centre cell nearest the centre
    (one across, one down or up, as YOLOv5 assigns them; their offsets stay within the decoder's −0.5 to 1.5),
    unless a cell is another person's centre: when a crowd's score peak lands a cell off the centre, the box
    reported there fits the person instead of being one no loss ever taught. Of two persons whose centres share a
    cell the later one's box is taught there; of two neighbours claiming one cell, the earlier."""
    grid = size // stride
    weight = np.ones((grid, grid), np.float32)
    reg = np.zeros((4, grid, grid), np.float32)
    box = np.zeros((4, grid, grid), np.float32)
    mask = np.zeros((grid, grid), np.uint8)
    b = np.asarray(boxes, np.float64).reshape(-1, 4)
    w = np.maximum(b[:, 2] - b[:, 0], 1.0)
    h = np.maximum(b[:, 3] - b[:, 1], 1.0)
    cx, cy = (b[:, 0] + b[:, 2]) / 2.0 / stride, (b[:, 1] + b[:, 3]) / 2.0 / stride
    gx = np.clip(np.trunc(cx), 0, grid - 1).astype(np.intp)
    gy = np.clip(np.trunc(cy), 0, grid - 1).astype(np.intp)
    seen = np.asarray(visible) >= MIN_SEEN
    for oy in (-1, 0, 1):
        for ox in (-1, 0, 1):
            ys, xs = gy[~seen] + oy, gx[~seen] + ox
            ok = (ys >= 0) & (ys < grid) & (xs >= 0) & (xs < grid)
            weight[ys[ok], xs[ok]] = 0.0
    sigma = np.maximum(0.5, 0.1 * np.sqrt(w * h) / stride)[seen]
    heat = _heat(grid, gx[seen], gy[seen], sigma)
    b, w, h, cx, cy, gx, gy = b[seen], w[seen], h[seen], cx[seen], cy[seen], gx[seen], gy[seen]
    logs = np.stack([np.log(w / stride), np.log(h / stride)])
    last = _last_of_each(gy * grid + gx)
    reg[:, gy[last], gx[last]] = np.concatenate([[cx - gx, cy - gy], logs])[:, last]
    box[:, gy[last], gx[last]] = b.T[:, last]
    mask[gy, gx] = 1
    if neighbour_boxes:  # after every centre is placed: a centre cell keeps its own person's box
        across = np.where(cx - gx < 0.5, gx - 1, gx + 1)
        down = np.where(cy - gy < 0.5, gy - 1, gy + 1)
        who = np.repeat(np.arange(len(b)), 2)  # person by person, the cell across and then the one down
        nx = np.stack([across, gx], 1).reshape(-1)
        ny = np.stack([gy, down], 1).reshape(-1)
        ok = (nx >= 0) & (nx < grid) & (ny >= 0) & (ny < grid)
        who, nx, ny = who[ok], nx[ok], ny[ok]
        free = mask[ny, nx] == 0
        who, nx, ny = who[free], nx[free], ny[free]
        _, first = np.unique(ny * grid + nx, return_index=True)
        who, nx, ny = who[first], nx[first], ny[first]
        reg[:, ny, nx] = np.stack([cx[who] - nx, cy[who] - ny, logs[0, who], logs[1, who]])
        box[:, ny, nx] = b[who].T
        mask[ny, nx] = 1
    weight[heat >= 1.0] = 1.0
    return Targets(heat, weight, reg, box, mask)


__all__ = ["Targets", "sample_crops", "targets", "turn"]
