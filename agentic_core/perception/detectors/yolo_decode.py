"""YOLO-style model arithmetic in numpy: letterboxing a frame into the model's input, decoding the two export
layouts, non-maximum suppression (:mod:`.suppression`), and mapping boxes back to the frame's pixels.

Layouts (``layout``): ``"v8"`` is the YOLOv8/YOLO11 export, one output ``(1, 4 + nc, N)`` of rows
``cx, cy, w, h, score_0 … score_nc-1``; ``"v5"`` is the YOLOv5 export ``(1, N, 5 + nc)``: ``cx, cy, w, h,
objectness, class scores``, the score being objectness × class score. :func:`guess_layout` tells them apart by
which axis is the short one (N, the candidates, is in the thousands; the channels are 4 + nc or 5 + nc).

>>> import numpy as np
>>> box = letterbox_geometry((640, 480), (320, 320))
>>> box.scale, box.pad_x, box.pad_y
(0.5, 0.0, 40.0)
>>> to_frame(np.array([[10.0, 50.0, 30.0, 90.0]]), box).tolist()
[[20.0, 20.0, 60.0, 100.0]]
>>> nms(np.array([[0, 0, 10, 10], [1, 1, 11, 11], [50, 50, 60, 60]], float), np.array([0.9, 0.8, 0.7]), 0.5)
[0, 2]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from .suppression import iou, nms

Layout = Literal["v8", "v5"]
FloatArray = NDArray[np.float32]
PAD_VALUE = 114
"""The grey YOLO exports are trained to see in the letterbox's borders."""


@dataclass(frozen=True)
class Letterbox:
    """How a frame sits inside the model's input: scaled by ``scale``, then offset by the padding."""

    scale: float
    pad_x: float
    pad_y: float
    size: tuple[int, int]
    """The scaled frame's (width, height) in input pixels."""


@dataclass(frozen=True)
class Decoded:
    """Candidates from one output: boxes (N×4, x0 y0 x1 y1 in input pixels), best score and its class."""

    boxes: FloatArray
    scores: FloatArray
    classes: NDArray[np.int64]


def letterbox_geometry(frame_size: tuple[int, int], input_size: tuple[int, int]) -> Letterbox:
    """Fit a (width, height) frame into a (width, height) input, keeping its aspect, centred (whole-pixel padding)."""
    width, height = frame_size
    in_w, in_h = input_size
    scale = min(in_w / width, in_h / height)
    new_w, new_h = max(1, round(width * scale)), max(1, round(height * scale))
    return Letterbox(
        scale=scale, pad_x=float((in_w - new_w) // 2), pad_y=float((in_h - new_h) // 2), size=(new_w, new_h)
    )


def resize_bilinear(image: NDArray[np.uint8], size: tuple[int, int]) -> NDArray[np.float32]:
    """``image`` (H×W×C) resampled to (width, height) by bilinear interpolation, as float32 0–255; an area
    average first when shrinking by 2 or more, so thin people do not alias away."""
    out_w, out_h = size
    img = image.astype(np.float32)
    factor = int(min(img.shape[1] / out_w, img.shape[0] / out_h))
    if factor >= 2:
        h, w = (img.shape[0] // factor) * factor, (img.shape[1] // factor) * factor
        img = img[:h, :w].reshape(h // factor, factor, w // factor, factor, -1).mean(axis=(1, 3))
    src_h, src_w = img.shape[:2]
    if (src_w, src_h) == (out_w, out_h):
        return img
    ys = np.clip((np.arange(out_h, dtype=np.float32) + 0.5) * (src_h / out_h) - 0.5, 0, src_h - 1)
    xs = np.clip((np.arange(out_w, dtype=np.float32) + 0.5) * (src_w / out_w) - 0.5, 0, src_w - 1)
    y0, x0 = ys.astype(np.int64), xs.astype(np.int64)
    y1, x1 = np.minimum(y0 + 1, src_h - 1), np.minimum(x0 + 1, src_w - 1)
    wy, wx = (ys - y0)[:, None, None], (xs - x0)[None, :, None]
    top = img[y0][:, x0] * (1 - wx) + img[y0][:, x1] * wx
    bottom = img[y1][:, x0] * (1 - wx) + img[y1][:, x1] * wx
    result: NDArray[np.float32] = (top * (1 - wy) + bottom * wy).astype(np.float32)
    return result


def letterbox(image: NDArray[np.uint8], input_size: tuple[int, int], channels: int = 3) -> tuple[FloatArray, Letterbox]:
    """The model's input tensor (1×C×H×W, float32 in 0–1) for an RGB frame, and where the frame sits in it;
    ``channels`` 1 feeds the frame's luminance."""
    box = letterbox_geometry((image.shape[1], image.shape[0]), input_size)
    in_w, in_h = input_size
    if channels == 3 and image.shape[:2] == (in_h, in_w):  # the frame is the input: its planes, scaled to 0–1
        planes: FloatArray = np.ascontiguousarray(image.transpose(2, 0, 1)).astype(np.float32)[None]
        planes /= np.float32(255.0)
        return planes, box
    scaled = resize_bilinear(image, box.size)
    if channels == 1:
        scaled = (scaled @ np.array([0.299, 0.587, 0.114], dtype=np.float32))[:, :, None]
    if tuple(box.size) == (in_w, in_h):  # the frame fills the input: no padding to paste it into
        canvas = scaled
    else:
        canvas = np.full((in_h, in_w, channels), PAD_VALUE, dtype=np.float32)
        left, top = int(box.pad_x), int(box.pad_y)
        canvas[top : top + box.size[1], left : left + box.size[0]] = scaled
    tensor: FloatArray = np.ascontiguousarray(canvas.transpose(2, 0, 1)[None] / np.float32(255.0), dtype=np.float32)
    return tensor, box


def guess_layout(shape: tuple[int, ...]) -> Layout:
    """``"v8"`` when the channels come first (``(1, 4 + nc, N)``, fewer channels than candidates), else ``"v5"``."""
    return "v8" if shape[1] < shape[2] else "v5"


def decode(output: NDArray[np.floating], layout: Layout) -> Decoded:
    """The candidates of one ``(1, …)`` output in ``layout``: corner boxes in input pixels, score, class."""
    if layout == "v8" and output.shape[1] == 5:
        return _decode_one_class(output[0].astype(np.float32, copy=False))
    rows = output[0].T if layout == "v8" else output[0]
    rows = rows.astype(np.float32, copy=False)
    class_scores = rows[:, 4:] if layout == "v8" else rows[:, 5:] * rows[:, 4:5]
    classes = np.argmax(class_scores, axis=1).astype(np.int64)
    scores = class_scores[np.arange(len(rows)), classes]
    cx, cy, w, h = rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1).astype(np.float32)
    return Decoded(boxes=boxes, scores=scores.astype(np.float32), classes=classes)


def _decode_one_class(channels: FloatArray) -> Decoded:
    """:func:`decode` of a one-class v8 output (5×N), channel by channel: the same arithmetic on whole rows."""
    cx, cy, w, h, scores = channels
    boxes = np.empty((channels.shape[1], 4), dtype=np.float32)
    boxes[:, 0], boxes[:, 1] = cx - w / 2, cy - h / 2
    boxes[:, 2], boxes[:, 3] = cx + w / 2, cy + h / 2
    return Decoded(boxes=boxes, scores=scores.copy(), classes=np.zeros(channels.shape[1], dtype=np.int64))


NMS_IOU = 0.45
"""The overlap above which non-maximum suppression drops the lower-scoring box (ultralytics' default)."""


def kept_in_frame(
    decoded: Decoded,
    box: Letterbox,
    frame_size: tuple[int, int],
    *,
    score_threshold: float,
    max_detections: int,
    iou_threshold: float = NMS_IOU,
    allowed: NDArray[np.bool_] | None = None,
) -> tuple[FloatArray, FloatArray, NDArray[np.int64]]:
    """What a detector reports of its candidates: those scoring at least ``score_threshold`` (and ``allowed``), after
    NMS (per class, best first), their boxes mapped to the (width, height) frame and clipped to it; boxes, scores,
    classes."""
    keep = decoded.scores >= score_threshold
    if allowed is not None:
        keep &= allowed
    boxes, scores, classes = decoded.boxes[keep], decoded.scores[keep], decoded.classes[keep]
    order = nms(boxes, scores, iou_threshold, classes, max_detections)
    return to_frame(boxes[order], box, within=frame_size), scores[order], classes[order]


def to_frame(boxes: NDArray[np.floating], box: Letterbox, *, within: tuple[int, int] | None = None) -> FloatArray:
    """Boxes in input pixels mapped back to the frame's pixels; clipped to a (width, height) frame ``within``."""
    out = boxes.astype(np.float32).copy()
    out[:, 0::2] = (out[:, 0::2] - box.pad_x) / box.scale
    out[:, 1::2] = (out[:, 1::2] - box.pad_y) / box.scale
    if within is not None:
        np.clip(out[:, 0::2], 0, within[0], out=out[:, 0::2])
        np.clip(out[:, 1::2], 0, within[1], out=out[:, 1::2])
    return out


__all__ = [
    "NMS_IOU",
    "PAD_VALUE",
    "Decoded",
    "Layout",
    "Letterbox",
    "decode",
    "guess_layout",
    "iou",
    "kept_in_frame",
    "letterbox",
    "letterbox_geometry",
    "nms",
    "resize_bilinear",
    "to_frame",
]
