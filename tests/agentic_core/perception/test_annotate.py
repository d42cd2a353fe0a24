"""The annotated frame is a real PNG of the asked size, written where asked, with the casualty highlighted."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np

from agentic_core.perception.annotate import annotate_frame, casualties_of, scale_bar_m
from agentic_core.perception.pipeline import Perception
from flight.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame, project_points

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
HOME = (21.4133, 39.8933, 300.0)


def png_size(data: bytes) -> tuple[int, int]:
    assert data[:8] == PNG_SIGNATURE and data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def casualty_scene(frames: int = 15) -> Perception:
    """A person lying still, alone, and a small group nearby (30 m up, straight down)."""
    spec, pose = CameraSpec(), CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    people = np.array([[5.0, 12.0, -0.85], [-5.0, -10.0, -0.85], [-6.0, -10.5, -0.85], [-5.5, -9.0, -0.85]])
    pixels, _ = project_points(spec, pose, people)
    perception = Perception(home=HOME)
    for k in range(frames):
        detections = [
            Detection(
                class_name="person",
                box=BoundingBox(x_min=u - 20, y_min=v - 20, x_max=u + 20, y_max=v + 20),
                confidence=0.89,
            )
            for u, v in pixels
        ]
        perception.update(Frame(index=k, time_s=k / 30, spec=spec, pose=pose), detections)
    return perception


def test_snapshot_is_a_png_of_the_asked_size(tmp_path: Path) -> None:
    perception = casualty_scene()
    world = perception.world
    assert world is not None
    assert casualties_of(world) == ["P-01"]
    path = tmp_path / "alert.png"
    data = perception.snapshot(path, width_px=640)
    assert png_size(data) == (640, 360)
    assert path.read_bytes() == data
    assert len(data) > 5_000  # not an empty canvas


def test_a_frame_with_pixels_and_no_objects() -> None:
    spec = CameraSpec(width_px=320, height_px=240)
    image = np.zeros((240, 320, 3), dtype=np.uint8)
    image[:, :160] = (200, 180, 150)
    frame = Frame(index=3, time_s=0.1, spec=spec, pose=CameraPose(north_m=0, east_m=0, down_m=-30), image=image)
    perception = Perception(home=HOME)
    world = perception.update(frame, [])
    data = annotate_frame(frame, world, width_px=320, highlight=[])
    assert png_size(data) == (320, 240)


def test_scale_bar_lengths_are_round() -> None:
    assert scale_bar_m(0.028, 1920) == 10.0  # 54 m across at 30 m up: a 10 m bar
    assert scale_bar_m(0.0028, 1920) == 1.0
    assert scale_bar_m(0.28, 1920) == 100.0
