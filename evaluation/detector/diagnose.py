"""Where a pose's persons are lost: which are found, found only under the threshold, boxed wrongly or missed, and
whether the network had a fitting box somewhere that its peak test or NMS threw away.

Why: recall alone says how many are lost, not what loses them, and the fix differs (the label, the decoding, the box
regression or the score map). Each counted person of the pose falls in one class, in this order: ``found`` (matched,
as :func:`~evaluation.detector.scoring.match` matches, by a detection at the threshold), ``below threshold`` (matched
only by one scoring under it), ``box taken`` (a detection at the threshold fits them, IoU ≥ 0.5, but matched a
neighbour it fits better), ``wrong box`` (the best detection at the threshold overlaps them at IoU 0.3–0.5: a box of
the wrong size or place) and ``missed`` (none overlaps them at 0.3). Every lost person is also placed by what the
network's grid held for them: a cell whose box fits (IoU ≥ 0.5) scoring over the threshold (``beaten``: a neighbour's
score peak or NMS removed it), fitting cells all scoring under it (``weak``), or no fitting cell at all (``unseen``).

``python -m evaluation.detector.diagnose --weights DIR --altitude 30 --pose lying`` prints it for held-out renders
at the recipe's threshold (``docs/detector.md`` carries it for lying persons at 30 m).

>>> import numpy as np
>>> truth = np.array([[0, 0, 10, 20], [30, 0, 40, 20], [60, 0, 70, 20]], np.float32)
>>> dets = (np.array([[0, 0, 10, 20], [30, 5, 40, 13]], np.float32), np.array([0.9, 0.8], np.float32))
>>> cells = (np.array([[30, 0, 40, 19], [61, 0, 70, 20]], np.float32), np.array([0.7, 0.2], np.float32))
>>> c = classify(truth, np.ones(3, bool), dets, cells, 0.5)
>>> [CLASSES[k] for k in c.outcome], [CAUSES[k] for k in c.cause]
(['found', 'wrong box', 'missed'], ['-', 'beaten', 'weak'])
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from agentic_core.contracts.extras import require
from agentic_core.perception.detectors import OnnxDetector
from agentic_core.perception.detectors.suppression import iou_matrix
from agentic_core.perception.detectors.yolo_decode import decode, letterbox, to_frame
from flight.sim.render.dataset import MIN_SEEN

from .scoring import IOU_MATCH, match
from .train import Labelled

CLASSES = ("found", "below threshold", "box taken", "wrong box", "missed")
CAUSES = ("-", "beaten", "weak", "unseen")
"""For a lost person: a fitting cell over the threshold was removed, fitting cells all scored under it, none fitted."""
IOU_NEAR = 0.3
SEEN_BANDS = ((0.5, 0.7), (0.7, 0.9), (0.9, 1.01))
Boxes = NDArray[np.float32]


@dataclass(frozen=True)
class Classified:
    """Per labelled person of one frame: its class (index into :data:`CLASSES`, -1 when not counted) and, when
    lost, its cause (into :data:`CAUSES`; 0 otherwise); the best IoU of a detection at the threshold and that
    detection's box (NaN when none)."""

    outcome: NDArray[np.int64]
    cause: NDArray[np.int64]
    best_iou: NDArray[np.float64]
    best_box: NDArray[np.float32]


def classify(
    truth: Boxes,
    chosen: NDArray[np.bool_],
    detections: tuple[Boxes, NDArray[np.float32]],
    cells: tuple[Boxes, NDArray[np.float32]],
    threshold: float,
    ignore: NDArray[np.bool_] | None = None,
) -> Classified:
    """Classify the ``chosen`` true boxes of one frame from its detections (boxes, scores, any score) and the
    network's cells (every cell's box and its score before the peak test)."""
    skip = np.zeros(len(truth), bool) if ignore is None else np.asarray(ignore, bool)
    m = match([detections], [truth], [skip])
    boxes, scores = detections
    at = boxes[scores >= threshold]
    near = iou_matrix(truth, at) if len(at) else np.zeros((len(truth), 1))
    best = near.max(axis=1, initial=0.0)
    best_box = np.full((len(truth), 4), np.nan, np.float32)
    if len(at):
        best_box[best > 0] = at[near.argmax(axis=1)[best > 0]]
    fit = iou_matrix(truth, cells[0]) >= IOU_MATCH
    strong = (fit & (cells[1] >= threshold)[None, :]).any(axis=1)
    score = m.truth_score[0]
    outcome = np.select(
        [score >= max(threshold, 1e-12), score > 0, best >= IOU_MATCH, best >= IOU_NEAR], [0, 1, 2, 3], default=4
    ).astype(np.int64)
    cause = np.where(outcome == 0, 0, np.select([strong, fit.any(axis=1)], [1, 2], default=3)).astype(np.int64)
    counted = np.asarray(chosen, bool) & ~skip
    return Classified(np.where(counted, outcome, -1), np.where(counted, cause, 0), best, best_box)


@dataclass(frozen=True)
class Breakdown:
    """A pose's counted persons over many frames: how many in each class and cause, the share found by how much of
    them is seen, and the size of the best detection at the threshold against the label's, by the label's shape."""

    persons: int
    by_class: dict[str, int]
    by_cause: dict[str, int]
    by_seen: list[tuple[str, int, int]]
    """(band, persons, found)."""
    size: list[tuple[str, int, float, float]]
    """(label shape, persons with a detection at IoU ≥ 0.3, median detection/label width, height)."""


def score_before_peaks(proto: Any) -> str | None:
    """The tensor an export's 3×3 peak test (a max-pool over the unsqueezed scores) reads, None without one."""
    made = {out: node for node in proto.graph.node for out in node.output}
    for node in proto.graph.node:
        if node.op_type == "MaxPool" and node.input[0] in made and made[node.input[0]].op_type == "Unsqueeze":
            return str(made[node.input[0]].input[0])
    return None


def cells_session(model: Path) -> tuple[Any, str, str | None]:
    """An onnxruntime session of ``model`` whose second output is each cell's score before the peak test (none for
    a model without one), its input's name and that tensor's."""
    onnx: Any = require("onnx", "train")
    ort: Any = require("onnxruntime", "vision")
    proto = onnx.load(str(model))
    before = score_before_peaks(proto)
    del proto.graph.output[1:]
    if before is not None:
        proto.graph.output.append(onnx.helper.make_tensor_value_info(before, onnx.TensorProto.FLOAT, None))
    options = ort.SessionOptions()
    options.intra_op_num_threads = options.inter_op_num_threads = 1
    session = ort.InferenceSession(proto.SerializeToString(), options, providers=["CPUExecutionProvider"])
    return session, str(session.get_inputs()[0].name), before


def breakdown(detector: OnnxDetector, frames: Sequence[Labelled], threshold: float, pose: str) -> Breakdown:
    """Run ``detector`` (its own score floor) and its model's cells on ``frames``; classify the counted persons of
    ``pose`` at ``threshold``. One pass, as the grid read is one pass's: a close frame's second look is left out."""
    session, name, before = cells_session(detector.path)
    outcome, cause, seen, ratio, shape = [], [], [], [], []
    for f in frames:
        boxes, scores, _ = detector.detect_array(f.image)
        tensor, box = letterbox(f.image, detector.input_size, detector.channels)
        outputs = session.run(None, {name: tensor})
        decoded = decode(np.asarray(outputs[0]), "v8")
        pre = np.asarray(outputs[1]).reshape(-1) if before is not None else decoded.scores
        chosen = np.array([p == pose for p in f.poses], bool)
        grid = to_frame(decoded.boxes, box, within=(f.image.shape[1], f.image.shape[0]))
        c = classify(f.boxes, chosen, (boxes, scores), (grid, pre), threshold, f.visible < MIN_SEEN)
        keep = c.outcome >= 0
        outcome.append(c.outcome[keep])
        cause.append(c.cause[keep])
        seen.append(f.visible[keep])
        width, height = f.boxes[:, 2] - f.boxes[:, 0], f.boxes[:, 3] - f.boxes[:, 1]
        near = keep & (c.best_iou >= IOU_NEAR)
        b = c.best_box[near]
        ratio.append(np.column_stack([(b[:, 2] - b[:, 0]) / width[near], (b[:, 3] - b[:, 1]) / height[near]]))
        shape.append(np.maximum(width, height)[near] / np.maximum(np.minimum(width, height)[near], 1e-6))
    out, why, vis = np.concatenate(outcome), np.concatenate(cause), np.concatenate(seen)
    ratios, shapes = np.concatenate(ratio), np.concatenate(shape)
    lost = out > 0
    bands = [
        (f"{lo:g}–{min(hi, 1.0):g}", int(np.sum(inside)), int(np.sum(inside & (out == 0))))
        for lo, hi in SEEN_BANDS
        for inside in [(vis >= lo) & (vis < hi)]
    ]
    sizes: list[tuple[str, int, float, float]] = []
    for label, inside in (("all", np.ones(len(shapes), bool)), ("along an axis (long ≥ 2× short)", shapes >= 2.0),
                          ("diagonal (long < 1.3× short)", shapes < 1.3)):  # fmt: skip
        r = ratios[inside] if inside.any() else np.full((1, 2), np.nan)
        sizes.append((label, int(np.sum(inside)), float(np.median(r[:, 0])), float(np.median(r[:, 1]))))
    return Breakdown(
        persons=len(out),
        by_class={name: int(np.sum(out == k)) for k, name in enumerate(CLASSES)},
        by_cause={name: int(np.sum(lost & (why == k))) for k, name in enumerate(CAUSES) if k},
        by_seen=bands,
        size=sizes,
    )


def breakdown_lines(b: Breakdown) -> list[str]:
    """The breakdown as Markdown tables."""

    def share(n: int) -> str:
        return f"{n / b.persons:.3f}" if b.persons else "–"

    lost = sum(b.by_cause.values())
    return [
        "| class | persons | share |",
        "|---|---|---|",
        *(f"| {name} | {n} | {share(n)} |" for name, n in b.by_class.items()),
        "",
        f"The {lost} lost, by what the network's grid held for them:",
        "",
        "| cause | persons | share of all |",
        "|---|---|---|",
        f"| beaten: a cell's box fitted (IoU ≥ 0.5) and scored over the threshold, but a neighbour's score peak or "
        f"NMS removed it | {b.by_cause['beaten']} | {share(b.by_cause['beaten'])} |",
        f"| weak: fitting cells all scored under the threshold | {b.by_cause['weak']} | {share(b.by_cause['weak'])} |",
        f"| unseen: no cell's box fitted | {b.by_cause['unseen']} | {share(b.by_cause['unseen'])} |",
        "",
        "| share seen | persons | found |",
        "|---|---|---|",
        *(f"| {band} | {n} | {found / n:.3f} |" if n else f"| {band} | 0 | – |" for band, n, found in b.by_seen),
        "",
        "| label shape | with a detection at IoU ≥ 0.3 | its width / the label's (median) | height |",
        "|---|---|---|---|",
        *(f"| {label} | {n} | {w:.3f} | {h:.3f} |" for label, n, w, h in b.size),
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Print the breakdown of one pose at one altitude on the held-out renders, at the recipe's threshold."""
    from .evaluate import TEST_FRAMES, TEST_SEED
    from .report import frames_for, raw_detector
    from .train import RECIPE_NAME

    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.diagnose", description=__doc__)
    parser.add_argument("--weights", type=Path, required=True, help="the folder of person.onnx and person.json")
    parser.add_argument("--altitude", type=float, default=30.0)
    parser.add_argument("--pose", default="lying", choices=("standing", "walking", "sitting", "lying"))
    parser.add_argument("--cache", type=Path, help="a folder to keep the rendered frames in (read when there)")
    args = parser.parse_args(argv)
    from agentic_core.perception.detectors.ours import read_recipe

    threshold = float(read_recipe(args.weights).get("score_threshold", 0.25))
    frames = frames_for(TEST_SEED, TEST_FRAMES, (args.altitude,), args.cache)
    result = breakdown(raw_detector(args.weights), frames, threshold, args.pose)
    print(f"{args.pose} persons at {args.altitude:g} m, threshold {threshold:g} ({args.weights / RECIPE_NAME})")
    print("\n".join(breakdown_lines(result)))
    return 0


__all__ = [
    "CAUSES", "CLASSES", "Breakdown", "Classified", "breakdown", "breakdown_lines", "cells_session", "classify", "main",
    "score_before_peaks",
]  # fmt: skip

if __name__ == "__main__":
    sys.exit(main())
