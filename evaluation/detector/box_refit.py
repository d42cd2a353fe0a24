"""Re-fit the box rows of the person detector's last convolution on training renders, leaving its score row alone.

Why: the boxes of the shipped network are systematically off (a lying person's box too small when they lie
diagonally, and shifted towards the head: ``python -m evaluation.detector.diagnose``), and its last convolution, a
1×1 from the head's features to the score logit, the centre's offsets and the box's log size, was trained jointly with
the score. Refitting its four box rows alone, by least absolute deviations (what training's L1 loss minimises) at the
cells that give the detections, moves only the boxes: every score, and so every peak, the calibration and the
threshold, stays bit for bit. The convolution is one of the int8 model's float ends (:mod:`.quantise`), so the new
rows go straight into the shipped file.

``python -m evaluation.detector.box_refit --src DIR --out DIR`` reads ``DIR/person.onnx`` and its recipe, renders the
first frames of its training seeds, refits, and writes the model and the recipe (the new SHA-256, the old, what the
refit did) to ``--out``; then run :mod:`.report` on ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.extras import require
from agentic_core.perception.detectors.suppression import iou_matrix
from agentic_core.perception.detectors.yolo_decode import NMS_IOU, decode, letterbox, nms, to_frame
from flight.sim.render.dataset import MIN_SEEN

from .network import STRIDE
from .train import RECIPE_NAME, WEIGHTS_NAME, Labelled, TrainConfig, render_frames, sha256_of

LAST_CONV = "/net/head/head.1/Conv"
MIN_SCORE = 0.2
"""Detections scoring at least this are fitted (the operating threshold is about 0.34: those near it count)."""
MIN_IOU = 0.3
"""A detection is fitted to the counted person it overlaps most, when at least this much."""
FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class Samples:
    """Per fitted detection: the head's features (N×C) and the four box outputs' targets (N×4: the centre's x and y
    offset logits, the log width and height in cells)."""

    features: FloatArray
    targets: FloatArray


def _last_conv(proto: Any) -> tuple[str, str, str]:
    """The last convolution's input (the head's features), weight and bias names."""
    for node in proto.graph.node:
        if node.name == LAST_CONV:
            return str(node.input[0]), str(node.input[1]), str(node.input[2])
    raise ValueError(f"no {LAST_CONV} in the model: not an export of evaluation.detector.network")


def samples(model: Path, frames: Sequence[Labelled], *, min_score: float = MIN_SCORE) -> Samples:
    """Features and targets of every detection scoring ``min_score`` or more that overlaps a counted person."""
    onnx: Any = require("onnx", "train")
    ort: Any = require("onnxruntime", "vision")
    proto = onnx.load(str(model))
    features_name, _, _ = _last_conv(proto)
    proto.graph.output.append(onnx.helper.make_tensor_value_info(features_name, onnx.TensorProto.FLOAT, None))
    wanted = [proto.graph.output[0].name, features_name]
    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(proto.SerializeToString(), options, providers=["CPUExecutionProvider"])
    shape = session.get_inputs()[0].shape
    xs: list[FloatArray] = []
    ys: list[FloatArray] = []
    for f in frames:
        tensor, box = letterbox(f.image, (int(shape[3]), int(shape[2])))
        output, features = session.run(wanted, {session.get_inputs()[0].name: tensor})
        decoded = decode(np.asarray(output), "v8")
        cells = np.flatnonzero(decoded.scores >= min_score)
        cells = cells[nms(decoded.boxes[cells], decoded.scores[cells], NMS_IOU, None, len(cells))]
        counted = f.boxes[f.visible >= MIN_SEEN]
        if not len(cells) or not len(counted):
            continue
        overlap = iou_matrix(to_frame(decoded.boxes[cells], box), counted)
        best = overlap.argmax(axis=1)
        near = overlap[np.arange(len(cells)), best] >= MIN_IOU
        truth = (counted[best[near]].astype(np.float64) * box.scale) + [box.pad_x, box.pad_y, box.pad_x, box.pad_y]
        gy, gx = np.divmod(cells[near], features.shape[3])
        cx, cy = (truth[:, 0] + truth[:, 2]) / (2 * STRIDE), (truth[:, 1] + truth[:, 3]) / (2 * STRIDE)
        ox = np.clip((cx - gx + 0.5) / 2, 0.02, 0.98)
        oy = np.clip((cy - gy + 0.5) / 2, 0.02, 0.98)
        size = np.maximum(truth[:, 2:] - truth[:, :2], 1.0) / STRIDE
        xs.append(features[0][:, gy, gx].T.astype(np.float64))
        ys.append(np.column_stack([np.log(ox / (1 - ox)), np.log(oy / (1 - oy)), np.log(size)]))
    if not xs:
        raise ValueError("no detection overlaps a counted person: nothing to fit")
    return Samples(np.concatenate(xs), np.concatenate(ys))


def least_absolute(a: FloatArray, y: FloatArray, iterations: int = 30) -> FloatArray:
    """Coefficients minimising ``sum |a @ c - y|`` (iteratively reweighted least squares from the least-squares fit).

    >>> a = np.column_stack([np.arange(6.0), np.ones(6)])
    >>> [round(float(c), 3) + 0.0 for c in least_absolute(a, np.array([1.0, 2, 3, 4, 5, 40]))]  # one outlier
    [1.0, 1.0]
    """
    coef = np.asarray(np.linalg.lstsq(a, y, rcond=None)[0], dtype=np.float64)
    for _ in range(iterations):
        weight = np.sqrt(1.0 / np.maximum(np.abs(a @ coef - y), 1e-4))
        coef = np.asarray(np.linalg.lstsq(a * weight[:, None], y * weight, rcond=None)[0], dtype=np.float64)
    return coef


def refit(src: Path, out: Path, frames: Sequence[Labelled], *, min_score: float = MIN_SCORE) -> dict[str, Any]:
    """Write ``src`` with its box rows refitted on ``frames`` to ``out``; what was fitted and the mean absolute error
    of each box output before and after."""
    onnx: Any = require("onnx", "train")
    numpy_helper: Any = onnx.numpy_helper
    data = samples(src, frames, min_score=min_score)
    proto = onnx.load(str(src))
    _, weight_name, bias_name = _last_conv(proto)
    inits = {i.name: i for i in proto.graph.initializer}
    weight = numpy_helper.to_array(inits[weight_name]).astype(np.float64)
    bias = numpy_helper.to_array(inits[bias_name]).astype(np.float64)
    a = np.column_stack([data.features, np.ones(len(data.features))])
    before = a @ np.vstack([weight[1:, :, 0, 0].T, bias[1:]])
    new = np.column_stack([least_absolute(a, data.targets[:, k]) for k in range(4)])
    weight[1:, :, 0, 0], bias[1:] = new[:-1].T, new[-1]
    inits[weight_name].CopyFrom(numpy_helper.from_array(weight.astype(np.float32), weight_name))
    inits[bias_name].CopyFrom(numpy_helper.from_array(bias.astype(np.float32), bias_name))
    out.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(proto, str(out))
    names = ("x offset", "y offset", "log width", "log height")

    def errors(predicted: FloatArray) -> dict[str, float]:
        return dict(zip(names, np.abs(predicted - data.targets).mean(axis=0).round(4).tolist(), strict=True))

    return {
        "method": "the last convolution's box rows (centre offsets, log size) refitted by least absolute deviations "
        "on the head's features at detections overlapping a counted person (IoU >= 0.3); the score row untouched",
        "min_score": min_score,
        "samples": len(data.features),
        "mean_abs_error_before": errors(before),
        "mean_abs_error_after": errors(a @ new),
    }


def training_frames(config: dict[str, Any], frames: int, extra_frames: int) -> list[Labelled]:
    """The first ``frames`` of the recipe's training seed and ``extra_frames`` of its extra seed, as trained on."""
    width, height = int(config["width_px"]), int(config["height_px"])
    first = TrainConfig(altitudes_m=tuple(config["altitudes_m"]), width_px=width, height_px=height)
    out = render_frames(first, seed=int(config["data_seed"]), count=frames)
    if extra_frames and config.get("extra_seed") is not None:
        extra = TrainConfig(altitudes_m=tuple(config["extra_altitudes_m"]), width_px=width, height_px=height)
        out += render_frames(extra, seed=int(config["extra_seed"]), count=extra_frames)
    return out


def main(argv: Sequence[str] | None = None) -> int:
    """Refit the box rows of ``--src``'s model and write it with its recipe to ``--out``."""
    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.box_refit", description=__doc__)
    parser.add_argument("--src", type=Path, required=True, help="the folder of person.onnx and person.json")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--frames", type=int, default=240, help="frames of the training seed")
    parser.add_argument("--extra-frames", type=int, default=160, help="frames of the extra training seed")
    args = parser.parse_args(argv)
    recipe = json.loads((args.src / RECIPE_NAME).read_text())
    frames = training_frames(recipe["config"], args.frames, args.extra_frames)
    stats = refit(args.src / WEIGHTS_NAME, args.out / WEIGHTS_NAME, frames)
    seeds = {"seed": recipe["config"]["data_seed"], "frames": args.frames}
    if args.extra_frames and recipe["config"].get("extra_seed") is not None:
        seeds |= {"extra_seed": recipe["config"]["extra_seed"], "extra_frames": args.extra_frames}
    recipe["box_refit"] = {**stats, "data": seeds, "before_sha256": recipe["sha256"]}
    recipe["sha256"] = sha256_of(args.out / WEIGHTS_NAME)
    (args.out / RECIPE_NAME).write_text(json.dumps(recipe, indent=2) + "\n")
    print(json.dumps(recipe["box_refit"], indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
