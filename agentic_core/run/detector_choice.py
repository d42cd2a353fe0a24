"""Which detector a run or a campaign uses (``--detector``): ``sim``, the statistical simulated detector (the
default: fast, for large campaigns); ``onnx:PATH``, any YOLO-style ONNX model; ``ours``, the person detector trained
here and shipped with the package. The last two see pixels, so they turn the rendering camera on.

:class:`PixelDetector` is what a real detector runs behind: it runs the model on the rendering camera's frame (or
renders one itself from the scene state the loop moves, when the camera gave no pixels), and links each detection
to the person it covers (``truth_id``, for evaluation only: perception never reads it).

>>> parse_detector("sim"), parse_detector(" ours "), parse_detector("onnx:models/yolo11n.onnx")
('sim', 'ours', 'onnx:models/yolo11n.onnx')
>>> needs_pixels("sim"), needs_pixels("ours")
(False, True)
>>> parse_detector("yolo")
Traceback (most recent call last):
...
agentic_core.contracts.errors.InputError: --detector: 'yolo' is not one of sim, ours, onnx:PATH
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..contracts.camera import CameraSpec, Detection, Detector, Frame
from ..contracts.errors import InputError
from ..perception.detectors.suppression import iou_matrix

if TYPE_CHECKING:
    from flight.sim.detector import SimulatedDetector
    from flight.sim.render.renderer import SceneRenderer

PIXEL_SIZE = (640, 480)
"""The rendered frame's size (width, height) for a real detector: what ours was trained on."""


def parse_detector(text: str) -> str:
    """``text`` checked and trimmed; :class:`InputError` naming ``--detector`` when it is none of the choices."""
    choice = text.strip()
    if choice in ("sim", "ours"):
        return choice
    if choice.startswith("onnx:") and choice[5:].strip():
        return "onnx:" + choice[5:].strip()
    raise InputError(f"--detector: {text!r} is not one of sim, ours, onnx:PATH")


def needs_pixels(choice: str) -> bool:
    """Whether the detector reads ``Frame.image`` (so the camera must render)."""
    return parse_detector(choice) != "sim"


def camera_spec(choice: str, rate_hz: float = 30.0) -> CameraSpec:
    """The camera for ``choice``: the default one for ``sim``; 640×480 (:data:`PIXEL_SIZE`) when it renders."""
    if not needs_pixels(choice):
        return CameraSpec(rate_hz=rate_hz)
    return CameraSpec(rate_hz=rate_hz, width_px=PIXEL_SIZE[0], height_px=PIXEL_SIZE[1])


def load_detector(choice: str) -> Detector | None:
    """The model ``choice`` names (None for ``sim``: the loop keeps its simulated detector)."""
    choice = parse_detector(choice)
    if choice == "sim":
        return None
    from ..perception.detectors import OnnxDetector
    from ..perception.detectors.ours import load_ours

    return load_ours() if choice == "ours" else OnnxDetector(choice[5:], classes=None)


class PixelDetector:
    """A real detector over the frames of a moving scene; :meth:`see` gives the frame with its pixels (rendered
    here when the camera gave none) and the detections, each linked to the person whose projected box it overlaps
    most (IoU ≥ 0.3; the simulated detector's geometry, ``in_view``)."""

    def __init__(self, model: Detector, sim: SimulatedDetector, *, seed: int = 0) -> None:
        self.model = model
        self.sim = sim
        self.seed = seed
        self._renderer: SceneRenderer | None = None

    def see(self, frame: Frame) -> tuple[Frame, list[Detection]]:
        """Render ``frame`` unless it has pixels, detect, and link the detections to the scene's persons."""
        if frame.image is None:
            if self._renderer is None:
                from flight.sim.render.renderer import SceneRenderer

                self._renderer = SceneRenderer(self.sim.state, seed=self.seed)
            frame = frame.model_copy(update={"image": self._renderer.render_frame(frame).image})
        found = self.model.detect(frame)
        return frame, _link(found, self.sim, frame) if found else found


def _link(found: list[Detection], sim: SimulatedDetector, frame: Frame) -> list[Detection]:
    view = sim.in_view(frame)
    if not len(view.rows):
        return found
    ids = [sim.state.ids[int(r)] for r in view.rows]
    boxes = np.array([[d.box.x_min, d.box.y_min, d.box.x_max, d.box.y_max] for d in found])
    overlap = iou_matrix(boxes, view.boxes)  # every detection against every person in view at once
    best = np.argmax(overlap, axis=1).tolist()
    linked = (overlap[np.arange(len(found)), best] >= 0.3).tolist()
    return [
        d.model_copy(update={"truth_id": ids[b]}) if ok else d for d, b, ok in zip(found, best, linked, strict=True)
    ]


def pixel_detector(choice: str, sim: SimulatedDetector, *, seed: int = 0) -> PixelDetector | None:
    """The :class:`PixelDetector` for ``choice`` beside the simulated detector ``sim`` (None for ``sim``)."""
    model = load_detector(choice)
    return None if model is None else PixelDetector(model, sim, seed=seed)


__all__ = [
    "PIXEL_SIZE",
    "PixelDetector",
    "camera_spec",
    "load_detector",
    "needs_pixels",
    "parse_detector",
    "pixel_detector",
]
