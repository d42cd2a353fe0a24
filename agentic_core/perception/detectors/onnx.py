""":class:`OnnxDetector`: any YOLO-style ONNX model behind the :class:`~agentic_core.contracts.camera.Detector`
protocol, run on the CPU with onnxruntime (the ``vision`` extra).

A frame's pixels are letterboxed into the model's input, its output decoded (the YOLOv8/YOLO11 layout or the
YOLOv5 one, told apart by shape unless ``layout`` says), overlapping boxes suppressed per class, and the rest mapped
back to the frame's pixels. The raw score becomes the detection's confidence through a :class:`Calibration`
(the identity unless one is given; by the box's size when it has maps by size), so the World Model's ``conf`` is a
probability.

>>> from agentic_core.perception.detectors import OnnxDetector
>>> OnnxDetector("no/such/model.onnx")
Traceback (most recent call last):
...
agentic_core.contracts.errors.InputError: no/such/model.onnx: no such ONNX model file
"""

from __future__ import annotations

import ast
import os
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ...contracts.camera import BoundingBox, Detection, Frame
from ...contracts.errors import InputError
from ...contracts.extras import require
from ...contracts.input_files import check_input_file
from ...contracts.trusted import record_maker
from ..calibration import Calibration, long_sides
from .rescue import Rescue, rescued_scores
from .second_look import SecondLook
from .yolo_decode import NMS_IOU, Layout, decode, guess_layout, kept_in_frame, letterbox

MAX_MODEL_BYTES = 1 << 30
"""The largest model file read (1 GiB: a YOLO11x export is about 220 MB)."""
DEFAULT_INPUT = (640, 640)


def _class_names(meta: dict[str, str]) -> list[str] | None:
    """Class names from an export's metadata ``names`` (``{0: 'person', ...}``), if it has them."""
    raw = meta.get("names")
    if not raw:
        return None
    try:
        parsed = ast.literal_eval(raw)
    except (ValueError, SyntaxError):
        return None
    if isinstance(parsed, dict):
        return [str(parsed[k]) for k in sorted(parsed)]
    if isinstance(parsed, list | tuple):
        return [str(n) for n in parsed]
    return None


class OnnxDetector:
    """A YOLO-style ONNX model as a :class:`Detector`: ``detect(frame)`` on ``frame.image`` (H×W×3 uint8, RGB).

    ``class_names`` default to the model's metadata (an ultralytics export carries them), else ``person`` for a
    one-class model; ``classes`` keeps only those names (all when None). ``input_size`` (width, height) is needed
    only when the model's input has no fixed size. ``rescue`` gives back cells a centre-point model's own peak test
    removed in a crowd (:mod:`.rescue`; ours names it in its recipe); ``second_look`` runs the model twice on close
    frames, the second time shifted by half a grid cell (:mod:`.second_look`; ours names it too).
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        layout: Literal["auto", "v8", "v5"] = "auto",
        class_names: Sequence[str] | None = None,
        classes: Sequence[str] | None = None,
        score_threshold: float = 0.25,
        iou_threshold: float = NMS_IOU,
        input_size: tuple[int, int] | None = None,
        calibration: Calibration | None = None,
        max_detections: int = 300,
        threads: int = 1,
        rescue: Rescue | None = None,
        second_look: SecondLook | None = None,
    ) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise InputError(f"{path}: no such ONNX model file")
        check_input_file(self.path, "ONNX model", limit=MAX_MODEL_BYTES)
        ort: Any = require("onnxruntime", "vision")
        options = ort.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        try:
            self.session = ort.InferenceSession(str(self.path), options, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own unrelated classes for a bad file
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(f"{path}: not a usable ONNX model ({first[:200]})") from exc
        self.score_threshold = score_threshold
        self.iou_threshold = iou_threshold
        self.calibration = calibration or Calibration.identity()
        self.max_detections = max_detections
        self.input_name, self.channels, self.input_size = self._input(input_size)
        outputs = self.session.get_outputs()
        self.output_name: str = outputs[0].name
        self.rescue = rescue
        self.second_look = second_look
        if rescue is not None and rescue.output not in [o.name for o in outputs]:
            raise InputError(f"{self.path}: no output {rescue.output!r} to rescue crowded persons from")
        meta = dict(self.session.get_modelmeta().custom_metadata_map)
        self.class_names = list(class_names) if class_names is not None else _class_names(meta)
        self.layout: Layout | None = None if layout == "auto" else layout
        self.classes = None if classes is None else set(classes)

    def _input(self, size: tuple[int, int] | None) -> tuple[str, int, tuple[int, int]]:
        """The input's name, channel count and (width, height), from the model or ``size``."""
        inputs = self.session.get_inputs()
        if len(inputs) != 1 or len(inputs[0].shape) != 4:
            shapes = [list(i.shape) for i in inputs]
            raise InputError(f"{self.path}: a YOLO-style model takes one 1×C×H×W image; this one takes {shapes}")
        _, channels, height, width = inputs[0].shape
        fixed = isinstance(height, int) and isinstance(width, int)
        if size is None:
            size = (width, height) if fixed else DEFAULT_INPUT
        elif fixed and size != (width, height):
            raise InputError(f"{self.path}: input size {size} but the model takes {width}×{height}")
        if channels not in (1, 3):
            raise InputError(f"{self.path}: the model's input has {channels} channels; 1 or 3 are supported")
        return str(inputs[0].name), int(channels), (int(size[0]), int(size[1]))

    def _layout(self, shape: tuple[int, ...]) -> Layout:
        """The output's layout, checked against its shape and the class count (when the names are known)."""
        if len(shape) != 3 or shape[0] != 1:
            raise InputError(
                f"{self.path}: output shape {list(shape)} is not a YOLO detection head "
                "(expected (1, 4+nc, N) for YOLOv8/11 or (1, N, 5+nc) for YOLOv5)"
            )
        layout = self.layout or guess_layout(shape)
        channels = shape[1] if layout == "v8" else shape[2]
        extra = 4 if layout == "v8" else 5
        if channels - extra < 1:
            raise InputError(
                f"{self.path}: output shape {list(shape)} leaves no class scores in layout {layout} "
                "(the layout is told by shape; set it if the model has fewer candidates than channels)"
            )
        if self.class_names is not None and channels - extra != len(self.class_names):
            raise InputError(
                f"{self.path}: output shape {list(shape)} in layout {layout} has {channels - extra} classes "
                f"but {len(self.class_names)} names are known"
            )
        return layout

    def detect_array(
        self, image: NDArray[np.uint8], *, twice: bool = False, index: int = 0
    ) -> tuple[NDArray[np.float32], NDArray[np.float32], list[str]]:
        """Boxes (K×4, frame pixels, clipped), raw scores and class names of what the model finds in ``image``;
        looked at ``twice`` when the detector has a :class:`SecondLook` (:meth:`looks_twice` says when), with the
        shifts of the frame's ``index``."""
        if not (isinstance(image, np.ndarray) and image.ndim == 3 and image.shape[2] == 3 and image.dtype == np.uint8):
            got = f"{image.dtype} {list(image.shape)}" if isinstance(image, np.ndarray) else type(image).__name__
            raise InputError(f"{self.path}: a frame's image must be H×W×3 uint8 RGB; got {got}")
        if twice and self.second_look is not None:
            look = self.second_look
            return look.look(self._once, image, index=index, iou=self.iou_threshold, max_keep=self.max_detections)
        return self._once(image)

    def looks_twice(self, focal_px: float, height_m: float) -> bool:
        """Whether a frame from a camera of ``focal_px`` at ``height_m`` above the ground is looked at twice."""
        return self.second_look is not None and self.second_look.wanted(focal_px, height_m)

    def _once(self, image: NDArray[np.uint8]) -> tuple[NDArray[np.float32], NDArray[np.float32], list[str]]:
        """One pass of the model over a checked image."""
        height, width = image.shape[:2]
        tensor, box = letterbox(image, self.input_size, self.channels)
        wanted = [self.output_name] if self.rescue is None else [self.output_name, self.rescue.output]
        results = self.session.run(wanted, {self.input_name: tensor})
        output = np.asarray(results[0])
        decoded = decode(output, self._layout(tuple(int(n) for n in output.shape)))
        if self.rescue is not None:
            before = np.asarray(results[1], dtype=np.float32).reshape(-1)
            decoded = replace(decoded, scores=rescued_scores(decoded.boxes, decoded.scores, before, self.rescue))
        names = self.class_names or (["person"] if decoded.classes.max(initial=0) == 0 else None)
        allowed = None
        if self.classes is not None:
            allowed = np.isin(decoded.classes, [i for i, n in enumerate(names or []) if n in self.classes])
        mapped, scores, classes = kept_in_frame(
            decoded, box, (width, height), score_threshold=self.score_threshold, iou_threshold=self.iou_threshold,
            max_detections=self.max_detections, allowed=allowed,
        )  # fmt: skip
        labels = [names[c] if names and c < len(names) else str(c) for c in classes.tolist()]
        return mapped, scores, labels

    def detect(self, frame: Frame) -> list[Detection]:
        """The model's detections in ``frame``, confidences calibrated; a frame without pixels is an error."""
        if frame.image is None:
            raise InputError(
                f"{self.path}: frame {frame.index} has no pixels (Frame.image is None); an ONNX detector needs the "
                "rendering camera (--detector onnx:PATH turns it on)"
            )
        twice = self.looks_twice(frame.spec.focal_px, -frame.pose.down_m)  # height above home, as the camera knows it
        boxes, scores, labels = self.detect_array(frame.image, twice=twice, index=frame.index)
        conf = np.clip(self.calibration.apply(scores, long_sides(boxes)), 0.0, 1.0)
        if not (np.isfinite(boxes).all() and np.isfinite(conf).all()):  # validation says what is wrong
            return [
                Detection(
                    class_name=label,
                    box=BoundingBox(x_min=b[0], y_min=b[1], x_max=b[2], y_max=b[3]),
                    confidence=c,
                    truth_id=None,
                )
                for b, c, label in zip(boxes.tolist(), conf.tolist(), labels, strict=True)
                if b[2] > b[0] and b[3] > b[1]
            ]
        new_detection, new_box = _new_detection, _new_box
        return [  # finite, ordered, confidences in 0–1: the records validation would make (contracts.trusted)
            new_detection(
                {
                    "class_name": label,
                    "box": new_box({"x_min": b[0], "y_min": b[1], "x_max": b[2], "y_max": b[3]}),
                    "confidence": c,
                    "truth_id": None,
                }
            )
            for b, c, label in zip(boxes.tolist(), conf.tolist(), labels, strict=True)
            if b[2] > b[0] and b[3] > b[1]
        ]


_new_box = record_maker(BoundingBox)
_new_detection = record_maker(Detection)


__all__ = ["OnnxDetector"]
