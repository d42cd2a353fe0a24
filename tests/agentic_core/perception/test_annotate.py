"""The annotated frame is a real PNG of the asked size, written where asked, with the casualty highlighted."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np

from agentic_core.perception.annotate import annotate_frame, casualties_of, encode_png, scale_bar_m
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


# ---- what the picture shows (decoded with matplotlib's PNG reader, so the file is a standard PNG) ----

RED, BLUE, GREY, GROUND = (255, 45, 45), (53, 192, 255), (216, 216, 216), (107, 98, 86)


def decode(data: bytes) -> np.ndarray:
    """The PNG as an H×W×3 uint8 array."""
    from matplotlib.image import imread

    pixels = np.asarray(imread(io.BytesIO(data), format="png"))
    decoded: np.ndarray = np.round(pixels[:, :, :3] * 255).astype(np.uint8)
    return decoded


def near(pixel: np.ndarray, color: tuple[int, int, int], tolerance: int = 12) -> bool:
    return bool(np.all(np.abs(pixel.astype(int) - np.array(color)) <= tolerance))


def count(region: np.ndarray, color: tuple[int, int, int], tolerance: int = 40) -> int:
    return int(np.all(np.abs(region.astype(int) - np.array(color)) <= tolerance, axis=2).sum())


def test_encode_png_is_lossless() -> None:
    image = np.random.default_rng(1).integers(0, 256, size=(37, 53, 3), dtype=np.uint8)
    assert np.array_equal(decode(encode_png(image)), image)


def test_the_casualty_is_boxed_and_labelled_in_red_the_others_in_blue() -> None:
    perception = casualty_scene()
    boxes = perception.track_boxes()
    stray = BoundingBox(x_min=1500, y_min=800, x_max=1560, y_max=860)  # a detection no track took
    last = perception._last
    assert last is not None
    frame, detections, _, world = last
    data = annotate_frame(
        frame, world, detections=[*detections, Detection(class_name="person", box=stray, confidence=0.5)],
        boxes=boxes, width_px=640,
    )  # fmt: skip
    pixels = decode(data)
    scale = 640 / frame.spec.width_px

    def at(x: float, y: float) -> np.ndarray:
        pixel: np.ndarray = pixels[int(y * scale), int(x * scale)]  # the pixel holding that point
        return pixel

    casualty = boxes["P-01"]
    middle_x, middle_y = casualty.center
    assert near(at(middle_x, casualty.y_max), RED) and near(at(casualty.x_min, middle_y), RED)
    assert near(at(*casualty.center), GROUND)  # an outline, not a filled box
    top, left = round(casualty.y_min * scale), round(casualty.x_min * scale)
    label = pixels[max(0, top - 30) : top - 1, max(0, left - 400) : left + 400]
    assert count(label, RED) > 150  # "P-01: still ... s, ... m from anyone, conf ..." in red
    assert count(label, (53, 49, 43), tolerance=6) > 500  # on its translucent black backing
    for other in ("P-02", "P-03", "P-04"):
        box = boxes[other]
        assert near(at((box.x_min + box.x_max) / 2, box.y_min), BLUE)
    top, left = round(boxes["P-02"].y_min * scale), round(boxes["P-02"].x_min * scale)
    name = pixels[top - 12 : top - 2, left : left + 20]  # above the box's edge: its id, small, in blue
    bluish = (name[:, :, 2] > 170) & (name[:, :, 0] < 150)
    assert bluish.sum() > 10
    assert near(at((stray.x_min + stray.x_max) / 2, stray.y_min), GREY)
    caption = pixels[0:25, 0:250]
    assert count(caption, (255, 255, 255), tolerance=30) > 100  # "t=... s · frame ... · 4 objects"
    bar = pixels[int(0.93 * 360) : int(0.93 * 360) + 6, int(0.04 * 640) + 5 : int(0.04 * 640) + 40]
    assert count(bar, (255, 255, 255), tolerance=10) > 30  # the scale bar


def test_the_frames_own_pixels_show_under_the_annotations() -> None:
    spec = CameraSpec(width_px=320, height_px=240)
    image = np.zeros((240, 320, 3), dtype=np.uint8)
    image[:, :160] = (200, 180, 150)
    frame = Frame(index=3, time_s=0.1, spec=spec, pose=CameraPose(north_m=0, east_m=0, down_m=-30), image=image)
    world = Perception(home=HOME).update(frame, [])
    pixels = decode(annotate_frame(frame, world, width_px=640, highlight=[]))
    assert pixels.shape == (480, 640, 3)
    assert near(pixels[240, 100], (200, 180, 150), 0) and near(pixels[240, 600], (0, 0, 0), 0)


def test_drawing_from_threads_gives_the_same_picture() -> None:
    from concurrent.futures import ThreadPoolExecutor

    perception = casualty_scene()
    first = perception.snapshot(width_px=480)
    with ThreadPoolExecutor(4) as pool:
        pictures = list(pool.map(lambda _: perception.snapshot(width_px=480), range(8)))
    assert all(picture == first for picture in pictures)
