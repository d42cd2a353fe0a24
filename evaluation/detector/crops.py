"""Training samples for the person detector, in numpy: square crops of rendered frames (half around a person, half
anywhere), turned by one of the eight symmetries of the square (a camera looking down has no up), and the
centre-point targets of each crop at the network's stride.

>>> import numpy as np
>>> heat, reg, mask = targets(np.array([[10.0, 6.0, 18.0, 10.0]]), size=32, stride=4)
>>> heat.shape, float(heat[2, 3]), int(mask.sum()), [round(float(v), 3) for v in reg[:, 2, 3]]
((8, 8), 1.0, 1, [0.5, 0.0, 0.693, 0.0])
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float32]
U8 = NDArray[np.uint8]


def sample_crops(
    image: U8, boxes: FloatArray, rng: np.random.Generator, *, size: int = 160, count: int = 4
) -> list[tuple[U8, FloatArray]]:
    """``count`` crops of ``size`` pixels with the boxes whose centre falls inside (in crop pixels, unclipped)."""
    height, width = image.shape[:2]
    out: list[tuple[U8, FloatArray]] = []
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
        out.append((image[y0 : y0 + size, x0 : x0 + size], shifted.astype(np.float32)))
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


def targets(boxes: FloatArray, *, size: int, stride: int) -> tuple[FloatArray, FloatArray, NDArray[np.uint8]]:
    """For a square crop's boxes: the score target (a Gaussian bump at each centre cell, 1 exactly there), the
    regression targets at the centre cells (x and y offset in the cell, log of width and height in cells), and
    the mask of those cells."""
    grid = size // stride
    heat = np.zeros((grid, grid), np.float32)
    reg = np.zeros((4, grid, grid), np.float32)
    mask = np.zeros((grid, grid), np.uint8)
    ys, xs = np.mgrid[0:grid, 0:grid].astype(np.float32)
    for x0, y0, x1, y1 in boxes.tolist():
        w, h = max(x1 - x0, 1.0), max(y1 - y0, 1.0)
        cx, cy = (x0 + x1) / 2.0 / stride, (y0 + y1) / 2.0 / stride
        gx, gy = min(int(cx), grid - 1), min(int(cy), grid - 1)
        sigma = max(0.5, 0.1 * math.sqrt(w * h) / stride)
        bump = np.exp(-((xs - gx) ** 2 + (ys - gy) ** 2) / (2.0 * sigma * sigma))
        np.maximum(heat, bump, out=heat)
        reg[:, gy, gx] = (cx - gx, cy - gy, math.log(w / stride), math.log(h / stride))
        mask[gy, gx] = 1
    return heat, reg, mask


__all__ = ["sample_crops", "targets", "turn"]
