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


def targets(
    boxes: FloatArray, visible: FloatArray, *, size: int, stride: int, neighbour_boxes: bool = False
) -> Targets:
    """The :class:`Targets` of a square crop's boxes; those seen less than :data:`MIN_SEEN` are ignored.

    With ``neighbour_boxes`` the box is also taught at the two cells next to the centre cell nearest the centre
    (one across, one down or up, as YOLOv5 assigns them; their offsets stay within the decoder's −0.5 to 1.5),
    unless a cell is another person's centre: when a crowd's score peak lands a cell off the centre, the box
    reported there fits the person instead of being one no loss ever taught."""
    grid = size // stride
    heat = np.zeros((grid, grid), np.float32)
    weight = np.ones((grid, grid), np.float32)
    reg = np.zeros((4, grid, grid), np.float32)
    box = np.zeros((4, grid, grid), np.float32)
    mask = np.zeros((grid, grid), np.uint8)
    ys, xs = np.mgrid[0:grid, 0:grid].astype(np.float32)
    seen = visible >= MIN_SEEN
    placed: list[tuple[tuple[float, float, float, float], float, float, int, int, float, float]] = []
    for (x0, y0, x1, y1), counted in zip(boxes.tolist(), seen.tolist(), strict=True):
        w, h = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
        cx, cy = (x0 + x1) / 2.0 / stride, (y0 + y1) / 2.0 / stride
        gx, gy = min(max(int(cx), 0), grid - 1), min(max(int(cy), 0), grid - 1)
        if not counted:
            weight[max(gy - 1, 0) : gy + 2, max(gx - 1, 0) : gx + 2] = 0.0
            continue
        sigma = max(0.5, 0.1 * math.sqrt(w * h) / stride)
        bump = np.exp(-((xs - gx) ** 2 + (ys - gy) ** 2) / (2.0 * sigma * sigma))
        np.maximum(heat, bump, out=heat)
        reg[:, gy, gx] = (cx - gx, cy - gy, math.log(w / stride), math.log(h / stride))
        box[:, gy, gx] = (x0, y0, x1, y1)
        mask[gy, gx] = 1
        placed.append(((x0, y0, x1, y1), cx, cy, gx, gy, w, h))
    if neighbour_boxes:  # after every centre is placed: a centre cell keeps its own person's box
        for corners, cx, cy, gx, gy, w, h in placed:
            across = gx - 1 if cx - gx < 0.5 else gx + 1
            down = gy - 1 if cy - gy < 0.5 else gy + 1
            for nx, ny in ((across, gy), (gx, down)):
                if 0 <= nx < grid and 0 <= ny < grid and not mask[ny, nx]:
                    reg[:, ny, nx] = (cx - nx, cy - ny, math.log(w / stride), math.log(h / stride))
                    box[:, ny, nx] = corners
                    mask[ny, nx] = 1
    weight[heat >= 1.0] = 1.0
    return Targets(heat, weight, reg, box, mask)


__all__ = ["Targets", "sample_crops", "targets", "turn"]
