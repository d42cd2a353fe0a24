"""The sensor's tone curve read two bytes at a time gives every pixel the level one byte at a time gives it: for
every byte pair, for images of an odd number of bytes and for strided ones (which take the plain path)."""

from __future__ import annotations

import numpy as np
import pytest

from flight.sim.render.sensor import Sensor, _blur, _look_up


def _levels(gain: float) -> np.ndarray:
    levels: np.ndarray = np.minimum(np.arange(256) * gain, 255.0).astype(np.int16)
    return levels


@pytest.mark.parametrize("gain", [0.94, 1.0, 1.06])
def test_every_byte_pair_is_looked_up_as_two_bytes(gain: float) -> None:
    levels = _levels(gain)
    every_pair = np.stack(np.meshgrid(np.arange(256), np.arange(256), indexing="ij"), axis=-1).astype(np.uint8)
    image = every_pair.reshape(128, 512, 2).reshape(128, 1024)[:, :, None].repeat(3, axis=2).copy()
    assert np.array_equal(_look_up(levels, image), levels[image])


@pytest.mark.parametrize("shape", [(7, 5, 3), (1, 1, 3), (480, 640, 3), (3, 4, 1)])
def test_any_shape_and_layout_is_looked_up_as_one_byte_at_a_time(shape: tuple[int, int, int]) -> None:
    levels = _levels(1.03)
    image = np.random.default_rng(1).integers(0, 256, shape, dtype=np.uint8)
    assert np.array_equal(_look_up(levels, image), levels[image])
    strided = np.random.default_rng(2).integers(0, 256, (shape[0], 2 * shape[1], shape[2]), dtype=np.uint8)[:, ::2]
    assert np.array_equal(_look_up(levels, strided), levels[strided])


@pytest.mark.parametrize("shape", [(5, 7, 3), (48, 64, 3)])
def test_a_frame_is_exposed_as_the_one_byte_tone_curve_and_the_noise_make_it(shape: tuple[int, int, int]) -> None:
    image = np.random.default_rng(3).integers(0, 256, shape, dtype=np.uint8)
    sensor = Sensor(seed=4)
    out = sensor.expose(image, frame_index=1, blur_px=(1.5, -0.5))
    rng = np.random.default_rng([4, 51, 1])
    pick, gain = int(rng.integers(0, 4)), float(rng.uniform(0.94, 1.06))
    expected = _levels(gain)[_blur(image, (1.5, -0.5))] + sensor._noise(shape)[pick]
    assert np.array_equal(out, np.clip(expected, 0, 255).astype(np.uint8))
