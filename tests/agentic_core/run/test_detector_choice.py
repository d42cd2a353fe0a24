"""``--detector``: the choices are checked before anything starts, a bad model is one line naming it (exit 2), and
a real detector sees rendered pixels of the scene the loop moves, its detections linked to the persons they cover."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agentic_core.cli import main
from agentic_core.contracts.camera import BoundingBox, CameraPose, Detection, Frame
from agentic_core.contracts.errors import InputError
from agentic_core.run.detector_choice import PixelDetector, camera_spec, needs_pixels, parse_detector
from agentic_core.run.perception_loop import PerceptionLoop
from flight.sim.detector import SimulatedCamera, SimulatedDetector
from flight.sim.render.renderer import SceneRenderer
from flight.sim.scene import SceneState
from flight.sim.scene_file import load_scene

REPO = Path(__file__).resolve().parents[3]
EMERGENCY = REPO / "scenes" / "hajj_emergency.yaml"


class Recording:
    """A detector that keeps every frame it is given and finds, each time, the boxes it was told to."""

    def __init__(self, boxes: list[tuple[float, float, float, float]]) -> None:
        self.boxes = boxes
        self.frames: list[Frame] = []

    def detect(self, frame: Frame) -> list[Detection]:
        self.frames.append(frame)
        return [
            Detection(class_name="person", box=BoundingBox(x_min=a, y_min=b, x_max=c, y_max=d), confidence=0.9)
            for a, b, c, d in self.boxes
        ]


@pytest.mark.parametrize("text", ["", "yolo", "onnx:", "onnx:   ", "SIM", "ours:x"])
def test_unknown_choices_are_refused(text: str) -> None:
    with pytest.raises(InputError, match=r"--detector: .* is not one of sim, ours, onnx:PATH"):
        parse_detector(text)


def test_pixels_and_the_camera_follow_the_choice() -> None:
    assert not needs_pixels("sim") and needs_pixels("ours") and needs_pixels("onnx:m.onnx")
    assert (camera_spec("sim").width_px, camera_spec("ours", 10.0).width_px) == (1920, 640)
    assert camera_spec("onnx:m.onnx", 10.0).rate_hz == 10.0


def test_a_real_detector_sees_the_rendered_frame_and_its_hits_are_linked_to_persons() -> None:
    scene = load_scene(EMERGENCY)
    pose = CameraPose(north_m=150.0, east_m=10.0, down_m=-30.0)
    frame = SimulatedCamera(camera_spec("ours")).capture(pose, 0.0)
    rendered = SceneRenderer(SceneState(scene), seed=1).render_frame(frame)
    casualty = rendered.persons.ids.index("P-12")
    x0, y0, x1, y1 = (float(v) for v in rendered.persons.boxes[casualty])
    model = Recording([(x0, y0, x1, y1), (1.0, 1.0, 2.0, 2.0)])
    seen, found = PixelDetector(model, SimulatedDetector(scene, seed=1), seed=1).see(frame)
    image = model.frames[0].image
    assert seen.image is image and image.shape == (480, 640, 3) and image.dtype == np.uint8
    assert np.array_equal(image, rendered.image)  # the same scene, seed and frame: the same pixels
    assert [d.truth_id for d in found] == ["P-12", None]


def test_a_frame_with_pixels_is_not_rendered_again() -> None:
    sim = SimulatedDetector(load_scene(EMERGENCY), seed=1)
    frame = SimulatedCamera(camera_spec("ours")).capture(CameraPose(north_m=0, east_m=0, down_m=-30), 0.0)
    mine = np.full((480, 640, 3), 7, np.uint8)
    model = Recording([])
    seen, _ = PixelDetector(model, sim).see(frame.model_copy(update={"image": mine}))
    assert model.frames[0].image is mine and seen.image is mine


def test_the_loop_with_an_onnx_model_runs_it_on_pixels(tmp_path: Path) -> None:
    pytest.importorskip("onnxruntime")
    from tests.agentic_core.perception.detectors.onnx_models import constant_model, v8_output

    model = constant_model(tmp_path / "m.onnx", v8_output([[320, 320, 16, 16, 0.9]] + [[0, 0, 0, 0, 0]] * 7),
                           input_shape=(1, 3, 480, 640))  # fmt: skip
    scene = load_scene(EMERGENCY)
    loop = PerceptionLoop(scene, seed=1, camera=SimulatedCamera(camera_spec("ours")), detector=f"onnx:{model}")
    assert loop.pixels is not None and type(loop.camera).__name__ == "RenderingCamera"
    for k in range(3):
        loop.observe(CameraPose(north_m=150.0, east_m=10.0, down_m=-30.0), k / 30.0)
    assert loop.frames == 3 and loop.detector.state.time_s == pytest.approx(2 / 30.0)


def test_bad_detectors_are_one_line_and_status_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    mission = str(REPO / "missions" / "hajj_emergency.yaml")
    base = ["run", mission, "--runs-dir", str(tmp_path), "--quiet", "--gcs", "none"]
    assert main([*base, "--detector", "yolo"]) == 2
    assert "error: --detector: 'yolo' is not one of sim, ours, onnx:PATH" in capsys.readouterr().err
    missing = tmp_path / "nope.onnx"
    assert main([*base, "--detector", f"onnx:{missing}"]) == 2
    err = capsys.readouterr().err
    assert f"error: {missing}: no such ONNX model file" in err and "Traceback" not in err
    junk = tmp_path / "junk.onnx"
    junk.write_text("not a model")
    assert main([*base, "--detector", f"onnx:{junk}"]) == 2
    assert f"error: {junk}: not a usable ONNX model" in capsys.readouterr().err


def test_the_campaign_refuses_an_unknown_detector(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    args = ["eval", "campaign", "--scenes", "1", "--out", str(tmp_path / "c"), "--quiet", "--detector", "x"]
    assert main(args) == 2
    assert "--detector: 'x' is not one of sim, ours, onnx:PATH" in capsys.readouterr().err
