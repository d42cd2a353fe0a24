"""The detector's faster paths give what the general ones give, to the bit: a frame the size of the model's input
made into the input tensor, a one-class output decoded, and detections built from trusted numbers, which equal
validated records field by field (and a box or score that is not finite still goes through validation)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from agentic_core.contracts.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame

from .onnx_models import constant_model, v8_output

detectors = pytest.importorskip("agentic_core.perception.detectors")
yolo = pytest.importorskip("agentic_core.perception.detectors.yolo_decode")


def test_a_frame_the_size_of_the_input_becomes_the_tensor_the_general_path_makes() -> None:
    image = np.random.default_rng(4).integers(0, 256, (48, 64, 3), dtype=np.uint8)
    tensor, box = yolo.letterbox(image, (64, 48))
    general = np.ascontiguousarray(
        yolo.resize_bilinear(image, box.size).transpose(2, 0, 1)[None] / np.float32(255.0), dtype=np.float32
    )
    assert tensor.dtype == np.float32 and tensor.flags.c_contiguous
    assert np.array_equal(tensor, general) and (box.scale, box.pad_x, box.pad_y) == (1.0, 0.0, 0.0)
    assert yolo.letterbox(image, (64, 64))[0].shape == (1, 3, 64, 64)  # not the input's size: padded as ever


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_one_class_output_decodes_as_any_output_does(dtype: type) -> None:
    rng = np.random.default_rng(5)
    output: np.ndarray = (rng.random((1, 5, 300)) * [[[640], [480], [40], [40], [1]]]).astype(dtype)
    one = yolo.decode(output, "v8")
    rows = output[0].T.astype(np.float32)
    cx, cy, w, h = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
    assert one.boxes.dtype == np.float32 and np.array_equal(one.boxes, boxes)
    assert np.array_equal(one.scores, rows[:, 4]) and one.scores.dtype == np.float32
    assert one.classes.dtype == np.int64 and not one.classes.any()
    two = yolo.decode(np.concatenate([output, np.zeros((1, 1, 300), dtype)], axis=1), "v8")
    assert np.array_equal(two.boxes, one.boxes) and np.array_equal(two.scores, one.scores)


def _frame() -> Frame:
    image = np.random.default_rng(0).integers(0, 255, (480, 640, 3), dtype=np.uint8)
    spec = CameraSpec(width_px=640, height_px=480)
    return Frame(index=0, time_s=0.0, spec=spec, pose=CameraPose(north_m=0, east_m=0, down_m=-30), image=image)


def test_detections_are_the_records_validation_makes(tmp_path: Path) -> None:
    rows = [[100, 100, 20, 40, 0.9], [300.25, 200.5, 10, 12, 0.6], [630, 470, 30, 30, 0.7], [50, 50, 8, 8, 1.0]]
    model = constant_model(tmp_path / "m.onnx", v8_output(rows + [[0, 0, 0, 0, 0.0]] * 4), input_shape=(1, 3, 480, 640))
    found = detectors.OnnxDetector(model).detect(_frame())
    assert len(found) == 4
    for d in found:
        checked = Detection(
            class_name=d.class_name,
            box=BoundingBox(x_min=d.box.x_min, y_min=d.box.y_min, x_max=d.box.x_max, y_max=d.box.y_max),
            confidence=d.confidence,
            truth_id=None,
        )
        assert d == checked and d.model_dump_json() == checked.model_dump_json()
        assert d.model_fields_set == checked.model_fields_set and d.box.model_fields_set == checked.box.model_fields_set
        assert all(type(v) is float for v in (d.confidence, d.box.x_min, d.box.y_min, d.box.x_max, d.box.y_max))
    assert found[2].box.x_max == 640.0 and found[2].box.y_max == 480.0  # clipped to the frame


def test_a_box_that_is_not_a_number_is_left_out_as_validation_leaves_it(tmp_path: Path) -> None:
    rows = [[100, 100, 20, 40, 0.9], [float("nan"), 300, 10, 10, 0.8], [400, 300, float("inf"), 10, 0.7]]
    model = constant_model(
        tmp_path / "nan.onnx", v8_output(rows + [[0, 0, 0, 0, 0.0]] * 5), input_shape=(1, 3, 480, 640)
    )
    found = detectors.OnnxDetector(model).detect(_frame())
    assert [(d.box.x_min, d.box.y_min, d.box.x_max) for d in found] == [(90.0, 80.0, 110.0), (0.0, 295.0, 640.0)]
    assert [d.confidence for d in found] == pytest.approx([0.9, 0.7])  # the NaN box is gone, the endless one clipped
    assert all(d.model_fields_set == {"class_name", "box", "confidence", "truth_id"} for d in found)
