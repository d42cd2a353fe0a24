"""The labelled frames a detector trains on: deterministic, labels inside the image, every pose present."""

from __future__ import annotations

import numpy as np

from flight.sim.render.dataset import MIN_SIZE_PX, LabelledFrame, labelled_frames, random_scene


def _frames(seed: int, count: int) -> list[LabelledFrame]:
    return list(labelled_frames(seed, count, altitudes_m=(20, 40), width=200, height=150))


def test_same_seed_same_frames() -> None:
    first, again, other = _frames(7, 3), _frames(7, 3), _frames(8, 1)
    for a, b in zip(first, again, strict=True):
        assert np.array_equal(a.image, b.image) and np.array_equal(a.boxes, b.boxes) and a.poses == b.poses
    assert not np.array_equal(first[0].image, other[0].image)


def test_labels_are_in_the_image_and_name_poses() -> None:
    frames = _frames(11, 5)
    poses: set[str] = set()
    for f in frames:
        assert f.image.shape == (150, 200, 3) and f.image.dtype == np.uint8
        assert f.boxes.dtype == np.float32 and f.boxes.shape == (len(f.poses), 4)
        assert f.altitude_m in (20.0, 40.0)
        b = f.boxes
        assert ((b[:, 0] >= 0) & (b[:, 1] >= 0) & (b[:, 2] <= 200) & (b[:, 3] <= 150)).all()
        assert (np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1]) >= MIN_SIZE_PX).all()
        poses |= set(f.poses)
    assert poses == {"standing", "walking", "sitting", "lying"}
    lying = sum(f.poses.count("lying") for f in frames)
    assert lying >= 0.1 * sum(len(f.poses) for f in frames)


def test_scenes_vary_and_validate() -> None:
    scenes = [random_scene(1, i) for i in range(6)]
    assert len({round(s.zones[0].density, 6) for s in scenes}) == 6
    assert any(s.landmarks for s in scenes) and any(s.actors for s in scenes)
