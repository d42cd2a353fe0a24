"""Crowded persons given back to a centre-point detector: the cells its 3×3 peak test removed, when a neighbour's
higher score belongs to someone else.

Why: our detector keeps a cell of its stride-4 grid only where its score is the largest of its 3×3 neighbourhood,
so of two persons whose centres lie within a cell or so of each other, as in a crowd seen from 30 m, one is lost even
when its own cell scored well and boxed it right. A removed cell is given back, with its score before the test, when
it scores at least ``min_score``, its box is at least ``min_long_px`` on its longer side, and no higher-scoring
neighbour predicts a centre within ``centre_ratio`` times the smaller of their two boxes' shorter sides: the cells
of one person predict nearly the same centre, a neighbour's do not. NMS then runs as for any model.

>>> import numpy as np
>>> r = Rescue(output="scores", min_score=0.5, centre_ratio=0.7, min_long_px=0.0, grid_width=3)
>>> boxes = np.zeros((9, 4), np.float32); boxes[:] = [0, 0, 8, 20]  # every cell boxes one person ...
>>> boxes[5] = [20, 0, 28, 20]  # ... but the cell right of the centre boxes another, 20 px away
>>> before = np.array([0, 0, 0, 0, 0.9, 0.6, 0, 0.7, 0], np.float32)
>>> peak = np.where(np.arange(9) == 4, before, 0).astype(np.float32)
>>> [round(float(v), 2) for v in rescued_scores(boxes, peak, before, r)]
[0.0, 0.0, 0.0, 0.0, 0.9, 0.6, 0.0, 0.0, 0.0]
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...contracts.errors import InputError

FloatArray = NDArray[np.float32]
_OFFSETS = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dy, dx) != (0, 0)]
_DY, _DX = np.array([o[0] for o in _OFFSETS]), np.array([o[1] for o in _OFFSETS])
_FIRST = np.array([o < (0, 0) for o in _OFFSETS])
"""Which neighbours come first in the grid's order: of two equal scores, the first one's cell is the peak."""


@dataclass(frozen=True)
class Rescue:
    """Which model output holds the scores before the peak test (one per cell, row-major on a grid ``grid_width``
    wide) and when a removed cell is given back."""

    output: str
    min_score: float
    centre_ratio: float
    min_long_px: float
    grid_width: int

    @classmethod
    def from_recipe(cls, entry: Any, where: Path) -> Rescue:
        """The recipe's ``rescue`` entry; :class:`InputError` naming the recipe and the field when one is wrong."""
        if not isinstance(entry, dict):
            raise InputError(f"{where}: rescue must be an object, got {type(entry).__name__}")

        def number(name: str, integer: bool = False) -> float:
            value = entry.get(name)
            if (
                isinstance(value, bool)
                or not isinstance(value, int | float)
                or (integer and not isinstance(value, int))
            ):
                raise InputError(f"{where}: rescue.{name} must be {'an integer' if integer else 'a number'}")
            return float(value)

        output = entry.get("output")
        if not isinstance(output, str):
            raise InputError(f"{where}: rescue.output must name a model output")
        width = int(number("grid_width", integer=True))
        if width < 1:
            raise InputError(f"{where}: rescue.grid_width must be at least 1")
        return cls(output, number("min_score"), number("centre_ratio"), number("min_long_px"), width)


def rescued_scores(boxes: FloatArray, peak: FloatArray, before: FloatArray, rescue: Rescue) -> FloatArray:
    """Every cell's score after the peak test (``peak``: 0 where it removed one), with the removed cells that
    :class:`Rescue` gives back scoring as ``before``; ``boxes`` are the cells' boxes (N×4, corners, input pixels)."""
    if not (len(boxes) == len(peak) == len(before)) or len(before) % rescue.grid_width:
        raise ValueError(
            f"{len(boxes)} boxes, {len(peak)} and {len(before)} scores do not fill a grid {rescue.grid_width} wide"
        )
    cand = np.flatnonzero((peak <= 0) & (before >= rescue.min_score))
    out = peak.copy()
    if len(cand):
        box = boxes[cand]
        width, height = box[:, 2] - box[:, 0], box[:, 3] - box[:, 1]
        tall = np.maximum(width, height) >= rescue.min_long_px
        cand, box, short = cand[tall], box[tall], np.minimum(width, height)[tall]
    if not len(cand):
        return out
    cols, cells = rescue.grid_width, len(before)
    row, col = np.divmod(cand, cols)
    r, c = row[:, None] + _DY, col[:, None] + _DX  # K×8: every candidate's neighbours at once
    inside = (r >= 0) & (c >= 0) & (c < cols) & (r * cols + c < cells)
    j = np.where(inside, r * cols + c, 0)
    own = before[cand][:, None]
    higher = inside & ((before[j] > own) | ((before[j] == own) & _FIRST))
    other = boxes[j]
    centre = (box[:, None, :2] + box[:, None, 2:]) / 2
    apart = np.hypot(*np.moveaxis((other[..., :2] + other[..., 2:]) / 2 - centre, -1, 0))
    near = np.minimum(np.minimum(other[..., 2] - other[..., 0], other[..., 3] - other[..., 1]), short[:, None])
    keep = ~(higher & (apart < rescue.centre_ratio * near)).any(axis=1)
    out[cand[keep]] = before[cand[keep]]
    return out


__all__ = ["Rescue", "rescued_scores"]
