"""The second look at a close frame (:mod:`agentic_core.perception.detectors.second_look`): the shifted pass's boxes
come back in the frame's own pixels, one person seen by both passes is one box at the better score, far frames are
looked at once, and the shipped detector, hovering for the emergency mission's close look, sees the collapsed
pilgrim sure enough from wherever its hover puts the grid."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray

from agentic_core.contracts.camera import CameraPose
from agentic_core.contracts.errors import InputError
from agentic_core.perception.detectors.onnx import OnnxDetector
from agentic_core.perception.detectors.ours import RECIPE, WEIGHTS, load_ours, read_recipe, weights_dir
from agentic_core.perception.detectors.second_look import Pass, SecondLook, shifted
from agentic_core.perception.pipeline import Perception

REPO = Path(__file__).resolve().parents[4]
FOCAL_PX = 355.4
"""The rendering camera's focal length: 640 px over 84°."""


def phase_detector(image: NDArray[np.uint8]) -> Pass:
    """A stand-in for a grid-bound model: it boxes the bright blob (clipped to the image, as a model's boxes are)
    and scores it 0.9 when the blob's top-left corner falls on the middle of a 4-px cell both ways, else 0.3."""
    columns = np.flatnonzero(image[:, :, 0].max(axis=0) > 200)
    rows = np.flatnonzero(image[:, :, 0].max(axis=1) > 200)
    if not len(columns):
        return np.zeros((0, 4), np.float32), np.zeros(0, np.float32), []
    x0, y0 = int(columns[0]), int(rows[0])
    score = 0.9 if x0 % 4 == 2 and y0 % 4 == 2 else 0.3
    box = [x0, y0, min(x0 + 6, image.shape[1]), min(y0 + 14, image.shape[0])]
    return np.array([box], np.float32), np.array([score], np.float32), ["person"]


def blob_at(x: int, y: int) -> NDArray[np.uint8]:
    image = np.zeros((64, 64, 3), np.uint8)
    image[y : y + 14, x : x + 6] = 255
    return image


@pytest.mark.parametrize(("x", "y"), [(20, 28), (20, 30), (22, 28), (22, 30)])
def test_two_frames_in_a_row_find_the_good_phase_and_box_the_person_where_they_are(x: int, y: int) -> None:
    """Even frames look unshifted and shifted right and down, odd ones right, and down: whichever of the cell's four
    phases the blob's corner is on, one of two frames in a row has a pass at the good one, and every frame gives
    one box, where the blob is in the frame."""
    look = SecondLook(shift_px=2)
    best = []
    for index in (0, 1):
        boxes, scores, labels = look.look(phase_detector, blob_at(x, y), index=index, iou=0.7, max_keep=9)
        assert labels == ["person"] and boxes.tolist() == [[float(x), float(y), x + 6.0, y + 14.0]]
        best.append(float(scores[0]))
    good = [any(((x + r) % 4, (y + d) % 4) == (2, 2) for r, d in look.shifts(index)) for index in (0, 1)]
    assert best == pytest.approx([0.9 if g else 0.3 for g in good])
    assert max(best) == pytest.approx(0.9) and min(best) == pytest.approx(0.3)  # one frame in two, here


def test_a_person_cut_by_the_frames_edge_keeps_their_box_to_the_edge_and_the_repeated_edge_alone_is_no_one() -> None:
    """The shifted pass does not see the frame's last columns and rows: a box reaching its edge reaches the
    frame's. A box of nothing but the repeated first columns would come back empty: it is dropped."""
    look = SecondLook(shift_px=2)
    for index in (0, 1):
        boxes, _, _ = look.look(phase_detector, blob_at(60, 52), index=index, iou=0.7, max_keep=9)
        assert boxes.tolist() == [[60.0, 52.0, 64.0, 64.0]], index

    def edge_only(image: NDArray[np.uint8]) -> Pass:
        return np.array([[0, 8, 2, 18]], np.float32), np.array([0.8], np.float32), ["person"]

    boxes, _, labels = look.look(edge_only, blob_at(20, 30), index=1, iou=0.7, max_keep=9)
    assert boxes.tolist() == [[0.0, 6.0, 2.0, 16.0]] and labels == ["person"]  # the down shift's box, moved back up


def test_two_frames_in_a_row_see_the_four_phases_of_a_cell() -> None:
    look = SecondLook(shift_px=2)
    assert {*look.shifts(0), *look.shifts(1)} == {(0, 0), (2, 2), (2, 0), (0, 2)} and look.shifts(2) == look.shifts(0)


def test_the_shift_repeats_the_edge_and_moves_the_rest() -> None:
    image = np.arange(5 * 6 * 3, dtype=np.uint8).reshape(5, 6, 3)
    moved = shifted(image, 2, 1)
    assert moved.shape == image.shape and moved.flags["C_CONTIGUOUS"]
    assert (moved[1:, 2:] == image[:-1, :-2]).all()
    assert (moved[:1, 2:] == image[:1, :-2]).all() and (moved[1:, :2] == image[:-1, :1]).all()
    assert shifted(image, 0, 0) is image


def test_nothing_found_by_either_pass_is_nothing() -> None:
    empty = np.zeros((32, 32, 3), np.uint8)
    boxes, scores, labels = SecondLook().look(phase_detector, empty, index=0, iou=0.7, max_keep=5)
    assert boxes.shape == (0, 4) and scores.shape == (0,) and labels == []


@pytest.mark.parametrize(
    ("height_m", "wanted"), [(15.8, True), (25.0, True), (26.0, False), (60.0, False), (0.0, True), (-3.0, True)]
)
def test_close_is_told_by_how_large_a_person_would_be(height_m: float, wanted: bool) -> None:
    assert SecondLook(from_person_px=24.0, person_m=1.7).wanted(FOCAL_PX, height_m) is wanted


@pytest.mark.parametrize(
    ("entry", "said"),
    [
        ({"shift_px": -2}, r"second_look\.shift_px: Input should be greater than or equal to 1"),
        ({"from_person_px": "near"}, r"second_look\.from_person_px: Input should be a valid number"),
        ({"shift": 2}, r"second_look\.shift: Extra inputs are not permitted"),
        ([2, 24], r"second_look: Input should be a valid dictionary"),
    ],
)
def test_a_recipe_with_a_broken_second_look_is_refused_by_name(tmp_path: Path, entry: object, said: str) -> None:
    pytest.importorskip("onnxruntime")
    shutil.copy(weights_dir() / WEIGHTS, tmp_path / WEIGHTS)
    recipe = read_recipe()
    recipe["second_look"] = entry
    (tmp_path / RECIPE).write_text(json.dumps(recipe))
    with pytest.raises(InputError, match=r"person\.json: " + said):
        load_ours(tmp_path)


def counting(detector: OnnxDetector) -> list[int]:
    """Count ``detector``'s passes over an image in the list's one element."""
    passes = [0]
    once = detector._once

    def counted(image: NDArray[np.uint8]) -> Pass:
        passes[0] += 1
        return once(image)

    detector._once = counted  # type: ignore[method-assign]
    return passes


def test_a_run_looks_twice_from_close_and_once_from_the_patrol_height_and_the_evaluation_does_as_a_run() -> None:
    pytest.importorskip("onnxruntime")
    from agentic_core.contracts.camera import Frame
    from evaluation.detector.evaluate import detect_all
    from flight.sim.render.camera import render_spec

    detector = load_ours()
    passes = counting(detector)
    image = np.full((480, 640, 3), 90, np.uint8)
    for down_m, want in ((-15.8, 2), (-25.0, 2), (-30.0, 1), (-60.0, 1), (0.5, 2)):  # last: under home, on its pad
        passes[0] = 0
        pose = CameraPose(north_m=0, east_m=0, down_m=down_m)
        detector.detect(Frame(index=3, time_s=0.0, spec=render_spec(5), pose=pose, image=image))
        assert passes[0] == want, down_m

    class Render:
        def __init__(self, altitude_m: float) -> None:
            self.image, self.altitude_m = image, altitude_m

    passes[0] = 0
    detect_all(detector, [Render(15.0), Render(20.0), Render(30.0), Render(50.0)])  # type: ignore[list-item]
    assert passes[0] == 2 + 2 + 1 + 1


def close_look_confidences(detector: OnnxDetector, across: int, frames: int = 8) -> list[float]:
    """The World Model's confidence in the collapsed pilgrim of the emergency scene after ``frames`` frames at 5 Hz
    from each of ``across``² hover positions 15.8 m up, within 1.4 m north and east of where the mission hovers;
    0 where no track stands on them."""
    from flight.sim.render.camera import RenderingCamera, render_spec
    from flight.sim.render.renderer import SceneRenderer
    from flight.sim.scene_file import load_scene

    scene = load_scene(REPO / "scenes" / "hajj_emergency.yaml")
    home = (scene.home.lat_deg, scene.home.lon_deg, scene.home.alt_msl_m)
    camera = RenderingCamera(SceneRenderer(scene, seed=0), render_spec(5))
    sure = []
    for north in np.linspace(148.8, 150.2, across):
        for east in np.linspace(13.1, 14.5, across):
            perception = Perception(home=home)
            for k in range(frames):
                frame = camera.capture(CameraPose(north_m=north, east_m=east, down_m=-15.77), time_s=54.0 + k / 5)
                world = perception.update(frame, detector.detect(frame))
            near = [o.conf for o in world.objects if math.hypot(o.pose.north - 150.0, o.pose.east - 14.0) < 2.0]
            sure.append(max(near, default=0.0))
    return sure


@pytest.mark.slow
def test_the_close_look_sees_the_casualty_sure_from_any_hover() -> None:
    """The emergency mission hovers 15.8 m over the collapsed pilgrim and asks the World Model for a confidence of
    0.5. A hover holds one view, which depends on where the aircraft stopped: from 25 of them within about a metre,
    after 1.6 s, the pilgrim is tracked at 0.5 or more from every one (one pass a frame: 4 of them under 0.5)."""
    pytest.importorskip("onnxruntime")
    detector = load_ours()
    assert detector.second_look is not None
    passes = counting(detector)
    sure = close_look_confidences(detector, across=5)
    assert passes[0] == 2 * 8 * len(sure)  # looked at twice, every frame
    assert min(sure) >= 0.5, np.round(sure, 2).tolist()
