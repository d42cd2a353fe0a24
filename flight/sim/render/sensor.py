"""What the sensor does to the light: motion blur along the image's motion during the exposure, a frame-to-frame
exposure wobble and read noise, all fixed by the seed and the frame's index.

Noise comes from a small bank of pre-drawn noise images (drawn once per image size), one chosen per frame, so a
frame costs an addition rather than a million fresh normal draws.

>>> image = np.full((8, 8, 3), 100, dtype=np.uint8)
>>> out = Sensor(seed=3).expose(image, frame_index=0, blur_px=(0.0, 0.0))
>>> out.shape, out.dtype.name, 90 < float(out.mean()) < 110
((8, 8, 3), 'uint8', True)
"""

from __future__ import annotations

import functools
import math
import sys

import numpy as np
from numpy.typing import NDArray

Image = NDArray[np.uint8]
BANK = 4
MAX_BLUR_STEPS = 6


class Sensor:
    """Noise and blur for one camera; ``noise_std`` in grey levels, ``exposure_s`` the shutter time."""

    def __init__(self, seed: int = 0, noise_std: float = 2.5, exposure_s: float = 1.0 / 250.0) -> None:
        self.seed = seed
        self.noise_std = noise_std
        self.exposure_s = exposure_s

    def expose(self, image: Image, frame_index: int, blur_px: tuple[float, float]) -> Image:
        """The picture as recorded: ``image`` blurred by ``blur_px`` (the image's motion during the exposure, in
        pixels), scaled by the frame's exposure, plus noise."""
        rng = np.random.default_rng([self.seed, 51, frame_index])
        pick, gain = int(rng.integers(0, BANK)), float(rng.uniform(0.94, 1.06))
        work = _blur(image, blur_px)
        levels = np.minimum(np.arange(256) * gain, 255.0).astype(np.int16)
        out = _look_up(levels, work)
        if self.noise_std > 0.0:
            out += self._noise(image.shape)[pick]
        np.clip(out, 0, 255, out=out)
        return out.astype(np.uint8)

    def _noise(self, shape: tuple[int, ...]) -> tuple[NDArray[np.int16], ...]:
        return _noise_bank(self.seed, shape, self.noise_std)


@functools.lru_cache(maxsize=4)
def _noise_bank(seed: int, shape: tuple[int, ...], std: float) -> tuple[NDArray[np.int16], ...]:
    """:data:`BANK` noise images, drawn once per process for a seed, size and strength (every camera shares them:
    a dataset makes a renderer per scene). Read-only."""
    rng = np.random.default_rng([seed, 52])
    bank = tuple(np.round(rng.standard_normal(shape) * std).astype(np.int16) for _ in range(BANK))
    for noise in bank:
        noise.setflags(write=False)
    return bank


def _look_up(levels: NDArray[np.int16], image: Image) -> NDArray[np.int16]:
    """``levels[image]``, read two bytes at a time: a table of every byte pair's two levels halves the look-ups."""
    if image.size % 2 or not image.flags.c_contiguous:
        single: NDArray[np.int16] = levels[image]
        return single
    pairs = np.empty((256, 256, 2), dtype=np.int16)  # a word is its first byte + 256 × its second (little-endian)
    first, second = (0, 1) if sys.byteorder == "little" else (1, 0)
    pairs[:, :, first] = levels[None, :]
    pairs[:, :, second] = levels[:, None]
    words = image.reshape(-1).view(np.uint16).astype(np.intp)
    out: NDArray[np.int16] = np.take(pairs.view(np.int32).reshape(-1), words).view(np.int16).reshape(image.shape)
    return out


def _blur(image: Image, blur_px: tuple[float, float]) -> Image:
    """The average of the image shifted along ``blur_px`` in up to :data:`MAX_BLUR_STEPS` steps (edges repeat)."""
    length = math.hypot(*blur_px)
    steps = min(round(length), MAX_BLUR_STEPS)
    if steps < 1:
        return image
    acc = image.astype(np.uint16)
    for k in range(1, steps + 1):
        dx = round(blur_px[0] * k / steps)
        dy = round(blur_px[1] * k / steps)
        acc += _shifted(image, dx, dy)
    out: Image = (acc // (steps + 1)).astype(np.uint8)
    return out


def _shifted(image: Image, dx: int, dy: int) -> Image:
    """``image`` moved by (dx, dy) pixels, the uncovered border repeating the edge."""
    h, w = image.shape[:2]
    dx, dy = max(-w + 1, min(dx, w - 1)), max(-h + 1, min(dy, h - 1))
    out = np.empty_like(image)
    ys, yd = (slice(0, h - dy), slice(dy, h)) if dy >= 0 else (slice(-dy, h), slice(0, h + dy))
    xs, xd = (slice(0, w - dx), slice(dx, w)) if dx >= 0 else (slice(-dx, w), slice(0, w + dx))
    out[yd, xd] = image[ys, xs]
    if dy > 0:
        out[:dy, xd] = out[dy, xd]
    elif dy < 0:
        out[h + dy :, xd] = out[h + dy - 1, xd]
    if dx > 0:
        out[:, :dx] = out[:, dx : dx + 1]
    elif dx < 0:
        out[:, w + dx :] = out[:, w + dx - 1 : w + dx]
    return out


__all__ = ["Sensor"]
