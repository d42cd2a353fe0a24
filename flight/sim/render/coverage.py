"""Who shows where: the renderer's own drawing order kept as an owner per pixel, so a frame can say how much of
each person is seen and how much another person drawn over them hides.

A pixel belongs to the last capsule that covered it at least half (the same order the colours are painted in);
a person's *footprint* is every pixel any of their capsules covered at least half, whoever was drawn after.

>>> cover = Coverage(4, 4)
>>> cover.paint(np.array([0, 1, 2, 3]), np.array([0, 0, 0, 0]))
>>> cover.paint(np.array([2, 3, 5]), np.array([1, 1, 1]))
>>> cover.shown_share(2).tolist()
[0.5, 1.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

IntArray = NDArray[np.int64]


class Coverage:
    """The owner of each pixel of a ``width``×``height`` frame (-1: none) and every owner's footprint."""

    def __init__(self, width: int, height: int) -> None:
        self.size = width * height
        self.owner = np.full(self.size, -1, dtype=np.int64)
        self._claims: list[IntArray] = []

    def paint(self, pixels: IntArray, owners: IntArray) -> None:
        """Owners take these flat pixel indices, later entries over earlier ones (as numpy assigns)."""
        self.owner[pixels] = owners
        self._claims.append(owners.astype(np.int64) * self.size + pixels)

    def shown_share(self, owners: int) -> NDArray[np.float64]:
        """For owners 0…``owners``-1, the share of their footprint they still own (0 for an empty footprint)."""
        claims = np.unique(np.concatenate(self._claims)) if self._claims else np.zeros(0, np.int64)
        footprint = np.bincount(claims // self.size, minlength=owners)[:owners]
        top = self.owner[self.owner >= 0]
        shown = np.bincount(top, minlength=owners)[:owners]
        return np.where(footprint > 0, shown / np.maximum(footprint, 1), 0.0)


__all__ = ["Coverage"]
