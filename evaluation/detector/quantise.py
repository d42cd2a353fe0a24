"""Quantise the trained person detector to 8-bit integers, calibrated on rendered frames.

Why: the network is most of the pixel pipeline's time; ONNX Runtime runs an int8 convolution in about half the time
of a float one on this class of CPU (VNNI), and static quantisation keeps the accuracy when its activation ranges
come from frames like those it will see. Only the network's body is quantised (every node under ``/net/`` but
:data:`FLOAT_NODES`): the image enters it and the score logits and box sizes leave it in float, and the decoding
that follows (centres and sizes in pixels, the peak test) stays float, so no box is rounded to a coarse pixel grid.

``python -m evaluation.detector.quantise --src DIR --out DIR`` reads ``DIR/person.onnx`` and its recipe (float, from
:mod:`.train`), renders ``--frames`` calibration frames of the training seed, and writes the int8 model and the
recipe (its SHA-256, the float model's, how it was quantised) to ``--out``; then run :mod:`.report` on ``--out``.
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agentic_core.contracts.extras import require
from agentic_core.perception.detectors.yolo_decode import letterbox

from .train import RECIPE_NAME, WEIGHTS_NAME, Labelled, TrainConfig, render_frames, sha256_of

FLOAT_NODES = ("/net/Sub", "/net/stem/stem.0/stem.0.0/Conv", "/net/stem/stem.0/stem.0.2/Relu", "/net/head/head.1/Conv")
"""Left in float: the input's shift and the first convolution (three channels are too few for int8 to be faster,
and quantising the image would cost more than it saves), and the head's last convolution (its outputs are the score
logit and the box's log size)."""
METHOD = (
    "ONNX Runtime static quantisation, QDQ: int8 weights per output channel, uint8 activations (min-max ranges on "
    "the calibration frames); the network's body only (not its first and last convolutions, nor the decoding)"
)


class _Reader:
    """Feeds the calibration frames to ONNX Runtime's calibrator, letterboxed as :class:`OnnxDetector` does."""

    def __init__(self, frames: Sequence[Labelled], size: tuple[int, int], name: str) -> None:
        self._frames = iter(frames)
        self._size, self._name = size, name

    def get_next(self) -> dict[str, np.ndarray] | None:
        frame = next(self._frames, None)
        if frame is None:
            return None
        tensor, _ = letterbox(frame.image, self._size, 3)
        return {self._name: tensor}


def quantise(src: Path, out: Path, frames: Sequence[Labelled]) -> str:
    """Write ``src`` (a float export of :class:`PersonNet`) as an int8 model at ``out``, its activation ranges from
    ``frames``; returns the new file's SHA-256."""
    onnx: Any = require("onnx", "train")
    require("onnxruntime", "vision")
    tools: Any = importlib.import_module("onnxruntime.quantization")
    shapes: Any = importlib.import_module("onnxruntime.quantization.shape_inference")

    model = onnx.load(str(src))
    shape = model.graph.input[0].type.tensor_type.shape.dim
    size, name = (int(shape[3].dim_value), int(shape[2].dim_value)), model.graph.input[0].name
    with tempfile.TemporaryDirectory() as scratch:
        prepared = Path(scratch) / "prepared.onnx"
        shapes.quant_pre_process(str(src), str(prepared), skip_symbolic_shape=True)
        nodes = onnx.load(str(prepared)).graph.node
        exclude = [n.name for n in nodes if not n.name.startswith("/net/") or n.name in FLOAT_NODES]
        tools.quantize_static(
            str(prepared), str(out), _Reader(frames, size, name), quant_format=tools.QuantFormat.QDQ,
            op_types_to_quantize=["Conv", "Relu", "Add", "Resize", "Sub"], per_channel=True,
            activation_type=tools.QuantType.QUInt8, weight_type=tools.QuantType.QInt8,
            calibrate_method=tools.CalibrationMethod.MinMax, nodes_to_exclude=exclude,
        )  # fmt: skip
    saved = onnx.load(str(out))
    del saved.metadata_props[:]
    saved.metadata_props.extend(model.metadata_props)
    onnx.save(saved, str(out))
    return sha256_of(out)


def main(argv: Sequence[str] | None = None) -> int:
    """The quantisation command line."""
    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.quantise", description=__doc__)
    parser.add_argument("--src", type=Path, required=True, help="folder of the float person.onnx and its recipe")
    parser.add_argument("--out", type=Path, required=True, help="folder for the int8 person.onnx and its recipe")
    parser.add_argument("--frames", type=int, default=24, help="calibration frames, of the training data seed")
    args = parser.parse_args(argv)
    recipe = json.loads((args.src / RECIPE_NAME).read_text())
    fields: dict[str, Any] = {k: tuple(v) if isinstance(v, list) else v for k, v in recipe["config"].items()}
    config = TrainConfig(**fields)
    frames = render_frames(config, count=args.frames)
    args.out.mkdir(parents=True, exist_ok=True)
    digest = quantise(args.src / WEIGHTS_NAME, args.out / WEIGHTS_NAME, frames)
    float_digest = recipe["sha256"]
    for key in ("calibration", "score_threshold", "calibration_data"):
        recipe.pop(key, None)  # fitted on the float model's scores: the report fits them again
    recipe["sha256"] = digest
    recipe["quantisation"] = {
        "method": METHOD,
        "float_sha256": float_digest,
        "calibration_frames": {"seed": config.data_seed, "count": args.frames, "altitudes_m": config.altitudes_m},
    }
    (args.out / RECIPE_NAME).write_text(json.dumps(recipe, indent=2) + "\n")
    print(f"wrote {args.out / WEIGHTS_NAME} ({digest}), from {float_digest}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
