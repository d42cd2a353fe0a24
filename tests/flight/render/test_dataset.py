"""The labelled frames a detector trains on: deterministic, labels inside the image, every pose present, and each
label the tight box of what is drawn of the person (not of their shadow, nor of an unrotated extent)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose, CameraSpec
from flight.sim.render import renderer as renderer_module
from flight.sim.render.coverage import Coverage
from flight.sim.render.dataset import MIN_SIZE_PX, LabelledFrame, labelled_frames, random_scene
from flight.sim.render.renderer import SceneRenderer

Box = NDArray[np.float64]


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


def _drawn_and_labelled(monkeypatch: pytest.MonkeyPatch, altitude: float, views: int) -> list[tuple[str, Box, Box]]:
    """(pose, label box, box of the pixels drawn for the person) of every person fully in the image and covered by
    no one, over ``views`` renders of training scenes; the drawn pixels are those the renderer's own coverage gives
    the person (each covered at least half by one of their capsules, the shadow never)."""
    seen: dict[str, Any] = {}

    class Recording(Coverage):
        def __init__(self, width: int, height: int) -> None:
            super().__init__(width, height)
            seen["cover"] = self

    drawing = SceneRenderer._draw_people

    def recording(self: SceneRenderer, image: Any, camera: Any, rows: Any, cover: Any = None) -> Any:
        seen["rows"] = rows
        return drawing(self, image, camera, rows, cover)

    monkeypatch.setattr(renderer_module, "Coverage", Recording)
    monkeypatch.setattr(SceneRenderer, "_draw_people", recording)
    rng = np.random.default_rng(17)
    out: list[tuple[str, Box, Box]] = []
    for k in range(views):
        renderer = SceneRenderer(random_scene(17, k), seed=17)
        spec = CameraSpec(width_px=640, height_px=480, hfov_deg=84.0, gimbal_pitch_deg=-90.0 + rng.uniform(0, 12))
        north, east = rng.uniform(-25, 25, 2)
        pose = CameraPose(north_m=north, east_m=east, down_m=-altitude, yaw_rad=rng.uniform(-np.pi, np.pi))
        persons = renderer.render(spec, pose, occlusion=True).persons
        assert persons.shown is not None
        owner = seen["cover"].owner.reshape(480, 640)
        index = {int(r): i for i, r in enumerate(seen["rows"])}
        for j in np.flatnonzero((persons.visible == 1.0) & (persons.shown == 1.0)):
            ys, xs = np.nonzero(owner == index[int(persons.rows[j])])
            drawn = np.array([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1], float)
            out.append((persons.poses[j], persons.boxes[j], drawn))
    return out


@pytest.mark.parametrize("altitude", [10.0, 30.0])
def test_a_label_is_the_tight_box_of_the_persons_drawn_pixels(monkeypatch: pytest.MonkeyPatch, altitude: float) -> None:
    # The label is the capsules' exact extent; the drawn pixels are whole pixels whose centres the capsules cover, so
    # each side may differ by up to a pixel, but never systematically: a box from the shadow, the unrotated body or
    # the legs' length regardless of heading would be larger on average, by far more than the 0.15 px allowed
    rows = _drawn_and_labelled(monkeypatch, altitude, views=12)
    for pose in ("standing", "walking", "sitting", "lying"):
        label = np.array([r[1] for r in rows if r[0] == pose])
        drawn = np.array([r[2] for r in rows if r[0] == pose])
        assert len(label) >= 20, f"{pose}: too few persons fully seen to judge ({len(label)})"
        outward = (drawn - label) * np.array([-1, -1, 1, 1])  # > 0: drawn pixels beyond the label
        assert np.abs(outward).max() <= 1.0, f"{pose} at {altitude:g} m: a side off by {np.abs(outward).max():.2f} px"
        assert np.abs(outward.mean(axis=0)).max() <= 0.15, f"{pose} at {altitude:g} m: {outward.mean(axis=0)}"
    lying = [r for r in rows if r[0] == "lying"]
    label, drawn = np.array([r[1] for r in lying]), np.array([r[2] for r in lying])
    sides = np.sort(label[:, 2:] - label[:, :2], axis=1)
    diagonal = sides[:, 1] < 1.3 * sides[:, 0]  # where an unrotated or shrunk extent would show most
    assert diagonal.sum() >= 5, f"only {diagonal.sum()} of {len(lying)} lying persons lie diagonally"
    outward = ((drawn - label) * np.array([-1, -1, 1, 1]))[diagonal]
    assert np.abs(outward.mean(axis=0)).max() <= 0.3, (
        f"diagonal lying persons at {altitude:g} m: {outward.mean(axis=0)}"
    )


def test_a_series_can_start_where_a_scene_begins_and_nowhere_else() -> None:
    whole = list(labelled_frames(5, 8, width=160, height=120))
    tail = list(labelled_frames(5, 4, width=160, height=120, start=4))
    assert len(tail) == 4
    for a, b in zip(whole[4:], tail, strict=True):
        assert np.array_equal(a.image, b.image) and np.array_equal(a.boxes, b.boxes)
    for start in (-4, 2):
        with pytest.raises(ValueError, match=f"start must be a multiple of 4 from 0, got {start}"):
            list(labelled_frames(5, 4, start=start))
