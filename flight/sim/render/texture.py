"""Periodic noise textures for the ground: computed once per process, then sliced per tile (no per-pixel hashing).

Each texture is a 512×512 float32 field of unit standard deviation that wraps at its edges (it is filtered white
noise in the Fourier domain), so a tile anywhere on the ground reads it at its pixel indices modulo 512.

>>> grain = texture("grain")
>>> grain.shape, grain.dtype.name, abs(float(grain.mean())) < 0.1
((512, 512), 'float32', True)
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

SIZE = 512
"""Texture side in texels; a multiple of the ground tile's side so a tile reads one contiguous block."""

_SCALES = {"grain": 0.8, "mottle": 6.0, "blotch": 40.0}
"""Correlation length of each texture, in texels."""


@functools.cache
def texture(name: str) -> NDArray[np.float32]:
    """The named periodic texture (``grain``, ``mottle`` or ``blotch``): zero mean, unit standard deviation."""
    scale = _SCALES[name]
    rng = np.random.default_rng([4242, len(name), int(scale * 10)])
    white = rng.standard_normal((SIZE, SIZE))
    k = np.fft.fftfreq(SIZE)
    k2 = k[:, None] ** 2 + k[None, :] ** 2
    field = np.fft.ifft2(np.fft.fft2(white) * np.exp(-k2 * (np.pi * scale) ** 2)).real
    field -= field.mean()
    field /= max(float(field.std()), 1e-12)
    out: NDArray[np.float32] = field.astype(np.float32)
    out.setflags(write=False)
    return out


__all__ = ["SIZE", "texture"]
