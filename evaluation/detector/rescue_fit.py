"""Choose, on the calibration renders, how the person detector gives back crowded persons its peak test removed
(:mod:`agentic_core.perception.detectors.rescue`), and ship the scores it needs as a second output of the model.

Why: in a crowd seen from 30 m the 3×3 peak test is the largest single loss of lying persons
(``python -m evaluation.detector.diagnose``: a cell boxed them right and scored over the threshold, and a neighbour's
peak removed it). Every setting of :data:`GRID` is scored on the calibration renders (seed 2, never the held-out
test) with its own best-F1 threshold; the one with the best F1 whose precision is at most :data:`MAX_PRECISION_LOSS`
under that of no rescue is kept, or none when none beats no rescue.

``python -m evaluation.detector.rescue_fit --src DIR --out DIR`` writes the model (its first output as before, the
scores before the peak test as ``scores``) and the recipe (the new SHA-256, the old, the rescue and how it was
chosen) to ``--out``; then run :mod:`.report` on ``--out``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agentic_core.contracts.extras import require
from agentic_core.perception.detectors.ours import MAX_DETECTIONS
from agentic_core.perception.detectors.rescue import Rescue, rescued_scores
from agentic_core.perception.detectors.yolo_decode import Decoded, decode, kept_in_frame, letterbox

from .diagnose import cells_session, score_before_peaks
from .evaluate import CALIBRATION_SEED, FLOOR, best_threshold, ignored
from .network import STRIDE
from .scoring import match, precision_recall
from .train import RECIPE_NAME, WEIGHTS_NAME, Labelled, sha256_of

OUTPUT = "scores"
GRID = {"min_score": (0.4, 0.5, 0.6), "centre_ratio": (0.5, 0.7, 1.0), "min_long_px": (0.0, 8.0, 12.0, 16.0)}
MAX_PRECISION_LOSS = 0.005
"""A rescue may cost at most this much precision on the calibration renders."""
Cells = tuple[np.ndarray, np.ndarray, np.ndarray, Any]


def with_scores_output(src: Path, dst: Path) -> int:
    """Write ``src`` with the scores before its peak test as a second output named :data:`OUTPUT`; the grid's width."""
    onnx: Any = require("onnx", "train")
    proto = onnx.load(str(src))
    before = score_before_peaks(proto)
    if before is None:
        raise ValueError(f"{src}: no 3×3 peak test over the scores: not an export of evaluation.detector.network")
    if OUTPUT not in [o.name for o in proto.graph.output]:
        proto.graph.node.append(onnx.helper.make_node("Identity", [before], [OUTPUT], name="/scores_before_peaks"))
        proto.graph.output.append(onnx.helper.make_tensor_value_info(OUTPUT, onnx.TensorProto.FLOAT, None))
    dst.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(proto, str(dst))
    width = proto.graph.input[0].type.tensor_type.shape.dim[3].dim_value
    return int(width) // STRIDE


def cells(model: Path, frames: Sequence[Labelled]) -> list[Cells]:
    """Per frame: every cell's box (input pixels), score after and before the peak test, and the letterbox."""
    session, name, _ = cells_session(model)
    shape = session.get_inputs()[0].shape
    out = []
    for f in frames:
        tensor, box = letterbox(f.image, (int(shape[3]), int(shape[2])))
        first, before = session.run(None, {name: tensor})
        decoded = decode(np.asarray(first), "v8")
        out.append((decoded.boxes, decoded.scores, np.asarray(before, np.float32).reshape(-1), box))
    return out


def score(data: list[Cells], frames: Sequence[Labelled], rescue: Rescue | None) -> dict[str, float]:
    """Threshold (best F1), precision, recall and F1 on ``frames`` with ``rescue`` (None: the peak test alone)."""
    found = []
    for (boxes, peak, before, box), f in zip(data, frames, strict=True):
        s = peak if rescue is None else rescued_scores(boxes, peak, before, rescue)
        decoded = Decoded(boxes=boxes, scores=s, classes=np.zeros(len(s), np.int64))
        size = (f.image.shape[1], f.image.shape[0])
        mapped, kept, _ = kept_in_frame(decoded, box, size, score_threshold=FLOOR, max_detections=MAX_DETECTIONS)
        found.append((mapped, kept))
    m = match(found, [f.boxes for f in frames], ignored(frames))
    threshold = best_threshold(m)
    precision, recall = precision_recall(m, threshold)
    f1 = 2 * precision * recall / max(precision + recall, 1e-12)
    return {"threshold": threshold, "precision": precision, "recall": recall, "f1": f1}


def choose(data: list[Cells], frames: Sequence[Labelled], grid_width: int) -> tuple[Rescue | None, dict[str, Any]]:
    """The rescue of :data:`GRID` to ship (None when none beats the peak test alone), and every setting's scores."""
    base = score(data, frames, None)
    tried = []
    best: tuple[float, Rescue] | None = None
    for low, ratio, size in itertools.product(*GRID.values()):
        rescue = Rescue(OUTPUT, low, ratio, size, grid_width)
        s = score(data, frames, rescue)
        tried.append({"min_score": low, "centre_ratio": ratio, "min_long_px": size, **s})
        allowed = s["precision"] >= base["precision"] - MAX_PRECISION_LOSS and s["f1"] > base["f1"]
        if allowed and (best is None or s["f1"] > best[0]):
            best = (s["f1"], rescue)
    return (best[1] if best else None), {"without": base, "tried": tried}


def main(argv: Sequence[str] | None = None) -> int:
    """Choose the rescue for ``--src``'s model and write the model and its recipe to ``--out``."""
    from .report import ALTITUDES_M, frames_for

    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.rescue_fit", description=__doc__)
    parser.add_argument("--src", type=Path, required=True, help="the folder of person.onnx and person.json")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--frames", type=int, default=120, help="calibration renders (seed 2)")
    parser.add_argument("--cache", type=Path, help="a folder to keep the rendered frames in (read when there)")
    args = parser.parse_args(argv)
    recipe = json.loads((args.src / RECIPE_NAME).read_text())
    width = with_scores_output(args.src / WEIGHTS_NAME, args.out / WEIGHTS_NAME)
    frames = frames_for(CALIBRATION_SEED, args.frames, ALTITUDES_M, args.cache)
    rescue, report = choose(cells(args.out / WEIGHTS_NAME, frames), frames, width)
    chosen = {"seed": CALIBRATION_SEED, "frames": args.frames, "max_precision_loss": MAX_PRECISION_LOSS}
    recipe.pop("rescue", None)
    if rescue is not None:
        recipe["rescue"] = {**rescue.__dict__, "chosen_on": chosen, "without": report["without"]}
        recipe["rescue"]["with"] = next(
            {k: t[k] for k in ("threshold", "precision", "recall", "f1")}
            for t in report["tried"]
            if (t["min_score"], t["centre_ratio"], t["min_long_px"])
            == (rescue.min_score, rescue.centre_ratio, rescue.min_long_px)
        )
        recipe["rescue"]["before_sha256"] = recipe["sha256"]
    recipe["sha256"] = sha256_of(args.out / WEIGHTS_NAME)
    (args.out / RECIPE_NAME).write_text(json.dumps(recipe, indent=2) + "\n")
    print(json.dumps(recipe.get("rescue"), indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
