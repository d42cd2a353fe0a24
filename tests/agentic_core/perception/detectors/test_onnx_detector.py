"""OnnxDetector: decoding of both YOLO layouts, the letterbox's mapping back to the frame, NMS, calibration, and
every bad model or frame refused with an error naming the file or the shape."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agentic_core.contracts.camera import CameraPose, CameraSpec, Frame
from agentic_core.contracts.errors import InputError
from agentic_core.perception.calibration import Calibration

from .onnx_models import constant_model, v5_output, v8_output

OnnxDetector = pytest.importorskip("agentic_core.perception.detectors").OnnxDetector


def frame(image: np.ndarray | None, index: int = 0) -> Frame:
    spec = CameraSpec(width_px=640, height_px=480)
    return Frame(index=index, time_s=0.0, spec=spec, pose=CameraPose(north_m=0, east_m=0, down_m=-30), image=image)


def pixels(width: int = 640, height: int = 480) -> np.ndarray:
    return np.random.default_rng(0).integers(0, 255, (height, width, 3), dtype=np.uint8)


def corners(detections) -> list[tuple[float, float, float, float]]:
    return [(d.box.x_min, d.box.y_min, d.box.x_max, d.box.y_max) for d in detections]


def test_v8_layout_letterbox_and_nms(tmp_path: Path) -> None:
    """640×480 into 320×320: scale 0.5, 40 px of padding above; input box (90, 80, 110, 120) is frame box
    (180, 80, 220, 160). The second box overlaps the first (IoU 0.82) and goes; the fourth is under threshold."""
    rows = [
        [100, 100, 20, 40, 0.9],
        [101, 101, 20, 40, 0.8],
        [200, 200, 10, 10, 0.6],
        [250, 150, 10, 10, 0.1],
    ]
    model = constant_model(tmp_path / "v8.onnx", v8_output(rows + [[0, 0, 0, 0, 0.0]] * 4))
    found = OnnxDetector(model).detect(frame(pixels()))
    assert corners(found) == [(180.0, 80.0, 220.0, 160.0), (390.0, 310.0, 410.0, 330.0)]
    assert [d.confidence for d in found] == pytest.approx([0.9, 0.6])
    assert {d.class_name for d in found} == {"person"} and all(d.truth_id is None for d in found)


def test_v5_layout_objectness_times_class_score_and_per_class_nms(tmp_path: Path) -> None:
    """Score = objectness × class score; two classes on one spot both survive, the same class does not."""
    rows = [
        [160, 160, 40, 40, 0.9, 1.0, 0.0],  # person 0.9
        [161, 160, 40, 40, 0.8, 0.0, 1.0],  # car 0.8, same place: another class, kept
        [162, 160, 40, 40, 0.9, 0.5, 0.0],  # person 0.45, overlaps the first person: suppressed
        [50, 300, 20, 20, 0.5, 0.4, 0.0],  # person 0.2 < 0.25: dropped
    ] + [[0, 0, 0, 0, 0, 0, 0]] * 6
    model = constant_model(tmp_path / "v5.onnx", v5_output(rows), metadata={"names": "{0: 'person', 1: 'car'}"})
    det = OnnxDetector(model)
    found = det.detect(frame(pixels()))
    assert [(d.class_name, round(d.confidence, 6)) for d in found] == [("person", 0.9), ("car", 0.8)]
    assert corners(found)[0] == (280.0, 200.0, 360.0, 280.0)
    only = OnnxDetector(model, classes=["car"]).detect(frame(pixels()))
    assert [d.class_name for d in only] == ["car"]


def test_layout_told_by_shape_and_by_option(tmp_path: Path) -> None:
    """Three v8 candidates make a (1, 5, 3) output, which by shape reads as v5; the option says v8."""
    out = v8_output([[100, 100, 20, 20, 0.9], [300, 200, 20, 20, 0.8], [200, 60, 10, 10, 0.7]])
    model = constant_model(tmp_path / "short.onnx", out)
    assert len(OnnxDetector(model, layout="v8").detect(frame(pixels()))) == 3
    with pytest.raises(InputError, match=r"output shape \[1, 5, 3\] leaves no class scores in layout v5"):
        OnnxDetector(model, layout="auto").detect(frame(pixels()))


def test_boxes_clipped_to_the_frame_and_padding_only_boxes_dropped(tmp_path: Path) -> None:
    rows: list[list[float]] = [[5, 100, 20, 20, 0.9], [160, 10, 40, 10, 0.8], [0, 0, 0, 0, 0], [0, 0, 0, 0, 0]]
    model = constant_model(tmp_path / "edge.onnx", v8_output(rows + [[0, 0, 0, 0, 0]] * 4))
    found = OnnxDetector(model).detect(frame(pixels()))
    assert corners(found) == [(0.0, 100.0, 30.0, 140.0)]  # x0 -10 clipped to 0; the second lies in the padding


def test_calibration_maps_the_score(tmp_path: Path) -> None:
    model = constant_model(tmp_path / "c.onnx", v8_output([[100, 100, 20, 20, 0.8]] + [[0, 0, 0, 0, 0]] * 5))
    cal = Calibration(scores=[0.0, 1.0], probs=[0.0, 0.5])
    (hit,) = OnnxDetector(model, calibration=cal).detect(frame(pixels()))
    assert hit.confidence == pytest.approx(0.4)


def test_calibration_by_size_reads_each_boxs_longer_side(tmp_path: Path) -> None:
    """The same raw score, 0.8, on a 20 px box and on a 60×10 px one (in the frame): each gets its size band's map."""
    rows = [[100, 100, 10, 10, 0.8], [200, 160, 30, 5, 0.8]] + [[0, 0, 0, 0, 0]] * 4
    model = constant_model(tmp_path / "s.onnx", v8_output(rows))
    small, large = {"scores": [0.0, 1.0], "probs": [0.0, 0.25]}, {"scores": [0.0, 1.0], "probs": [0.0, 1.0]}
    cal = Calibration(scores=[0.0, 1.0], probs=[0.0, 0.5], size_edges_px=[30.0], by_size=[small, large])
    found = OnnxDetector(model, calibration=cal).detect(frame(pixels()))
    sizes = sorted((round(d.box.x_max - d.box.x_min), round(d.confidence, 6)) for d in found)
    assert sizes == [(20, 0.2), (60, 0.8)]  # one map for all sizes: 0.4 both


def test_grayscale_and_dynamic_input(tmp_path: Path) -> None:
    out = v8_output([[100, 100, 20, 20, 0.8]] + [[0, 0, 0, 0, 0]] * 5)
    gray = constant_model(tmp_path / "g.onnx", out, input_shape=(1, 1, 240, 320))
    (hit,) = OnnxDetector(gray).detect(frame(pixels()))
    assert (hit.box.x_min, hit.box.y_min) == (180.0, 180.0)  # 640×480 into 320×240: scale 0.5, no padding
    dynamic = constant_model(tmp_path / "d.onnx", out, input_shape=(1, 3, "h", "w"))
    assert OnnxDetector(dynamic, input_size=(320, 320)).input_size == (320, 320)
    assert OnnxDetector(dynamic).input_size == (640, 640)


def test_letterbox_puts_the_frame_in_the_middle() -> None:
    from agentic_core.perception.detectors.yolo_decode import PAD_VALUE, letterbox

    image = np.full((480, 640, 3), 200, np.uint8)
    image[:, :320] = 10  # left half dark
    tensor, box = letterbox(image, (320, 320))
    assert tensor.shape == (1, 3, 320, 320) and (box.scale, box.pad_x, box.pad_y) == (0.5, 0.0, 40.0)
    assert np.allclose(tensor[0, :, :40], PAD_VALUE / 255) and np.allclose(tensor[0, :, 280:], PAD_VALUE / 255)
    assert np.allclose(tensor[0, :, 40:280, :160], 10 / 255) and np.allclose(tensor[0, :, 40:280, 160:], 200 / 255)


# hostile


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"nope\.onnx: no such ONNX model file"):
        OnnxDetector(tmp_path / "nope.onnx")


@pytest.mark.parametrize("content", [b"", b"this is not a model\n", bytes(range(256)) * 40])
def test_a_file_that_is_not_onnx_names_the_path(tmp_path: Path, content: bytes) -> None:
    path = tmp_path / "bad.onnx"
    path.write_bytes(content)
    with pytest.raises(InputError, match=r"bad\.onnx: not a usable ONNX model"):
        OnnxDetector(path)


def test_a_directory_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match=r"not a regular file"):
        OnnxDetector(tmp_path)


@pytest.mark.parametrize(
    "shape",
    [(1, 84), (2, 84, 100), (1, 4, 100), (1, 100, 4), (1, 2, 3, 4)],
)
def test_a_model_with_a_wrong_output_shape_names_the_shape(tmp_path: Path, shape: tuple[int, ...]) -> None:
    model = constant_model(tmp_path / "w.onnx", np.zeros(shape, np.float32))
    det = OnnxDetector(model)
    with pytest.raises(InputError, match=r"w\.onnx: output shape \[" + ", ".join(map(str, shape)) + r"\]"):
        det.detect(frame(pixels()))


def test_class_count_disagreeing_with_the_names(tmp_path: Path) -> None:
    model = constant_model(
        tmp_path / "n.onnx", v8_output([[1, 1, 1, 1, 0.5, 0.5]] * 8), metadata={"names": "['person']"}
    )
    with pytest.raises(InputError, match=r"has 2 classes but 1 names"):
        OnnxDetector(model).detect(frame(pixels()))


def test_a_model_with_two_inputs_or_no_image_input(tmp_path: Path) -> None:
    out = v8_output([[1, 1, 1, 1, 0.5]] * 8)
    with pytest.raises(InputError, match=r"two\.onnx: a YOLO-style model takes one"):
        OnnxDetector(constant_model(tmp_path / "two.onnx", out, extra_input=True))
    with pytest.raises(InputError, match=r"flat\.onnx: a YOLO-style model takes one 1×C×H×W image"):
        OnnxDetector(constant_model(tmp_path / "flat.onnx", out, input_shape=(1, 300)))
    with pytest.raises(InputError, match=r"c4\.onnx: the model's input has 4 channels"):
        OnnxDetector(constant_model(tmp_path / "c4.onnx", out, input_shape=(1, 4, 32, 32)))


def test_frames_without_good_pixels(tmp_path: Path) -> None:
    det = OnnxDetector(constant_model(tmp_path / "m.onnx", v8_output([[1, 1, 1, 1, 0.5]] * 8)))
    with pytest.raises(InputError, match=r"m\.onnx: frame 7 has no pixels"):
        det.detect(frame(None, index=7))
    bad: Any
    for bad, said in [
        (np.zeros((480, 640), np.uint8), r"uint8 \[480, 640\]"),
        (np.zeros((480, 640, 4), np.uint8), r"uint8 \[480, 640, 4\]"),
        (np.zeros((480, 640, 3), np.float32), r"float32 \[480, 640, 3\]"),
        ("pixels", r"str"),
    ]:
        with pytest.raises(InputError, match=r"must be H×W×3 uint8 RGB; got " + said):
            det.detect(frame(bad))
