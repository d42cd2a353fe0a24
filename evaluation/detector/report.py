"""Calibrate the trained person detector and write its report.

``python -m evaluation.detector.report --weights DIR --docs docs`` fits the calibration (isotonic, on renders of
:data:`CALIBRATION_SEED`) and the operating threshold (best F1 there), writes both into the recipe beside the
weights, then scores the detector on held-out renders (:data:`TEST_SEED`) at each altitude, 10–60 m: precision,
recall and AP@0.5 over all persons and by pose, the expected calibration error before and after calibration, and
the detect time per frame; ``docs/detector.md`` and the reliability diagram ``docs/detector_reliability.png``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from agentic_core.perception.calibration import Calibration, expected_calibration_error, reliability, size_bands
from agentic_core.perception.detectors import OnnxDetector
from agentic_core.perception.detectors.ours import MAX_DETECTIONS, passes
from agentic_core.perception.detectors.second_look import SecondLook
from flight.sim.render.dataset import MIN_SEEN

from .diagnose import breakdown, breakdown_lines
from .evaluate import (
    CALIBRATION_SEED,
    FLOOR,
    POSES,
    TEST_FRAMES,
    TEST_SEED,
    Scores,
    best_threshold,
    detect_all,
    evaluate,
    pose_masks,
    render_focal_px,
    scores_at,
)
from .train import RECIPE_NAME, WEIGHTS_NAME, Labelled, TrainConfig, load_frames, render_frames, save_frames

ALTITUDES_M = (10.0, 20.0, 30.0, 40.0, 50.0, 60.0)
"""The calibration renders' altitudes."""
REPORT_ALTITUDES_M = (10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0)
"""The held-out test's altitudes: 15 m is where a run's close look is."""
SIZE_EDGES_PX = [10.0, 16.0, 24.0]
"""The calibration's size bands (a box's longer side, px): on the calibration renders each holds at least 2,600
detections, and one raw score means a different precision in each (at 0.45–0.5: 0.70 under 10 px, 0.89 from
24 px)."""
DIAGNOSED = (30.0, "lying")
"""The altitude and pose whose losses the report breaks down (:mod:`.diagnose`): the issue's Done-when."""


def frames_for(seed: int, count: int, altitudes_m: tuple[float, ...], cache: Path | None) -> list[Labelled]:
    """Held-out or calibration renders, read from (or kept in) ``cache`` when one is given."""
    name = f"frames-{seed}-{count}-{'_'.join(f'{a:g}' for a in altitudes_m)}.npz"
    if cache is not None and (cache / name).is_file():
        return load_frames(cache / name)
    frames = render_frames(TrainConfig(altitudes_m=altitudes_m), seed=seed, count=count)
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
        save_frames(cache / name, frames)
    return frames


def _detect_time(detector: OnnxDetector, frames: Sequence[Labelled]) -> float:
    """Seconds per frame of ``detector`` on ``frames``, looking twice where a run would (after one untimed warm-up
    frame)."""
    detector.detect_array(frames[0].image)
    start = time.perf_counter()
    detect_all(detector, frames)
    return (time.perf_counter() - start) / len(frames)


def raw_detector(weights: Path, score_threshold: float = FLOOR) -> OnnxDetector:
    """The detector without calibration, keeping scores down to ``score_threshold`` (:data:`FLOOR` to score it;
    the operating threshold to time it as a run uses it); with the recipe's rescue of crowded persons and second
    look at close frames, as a run."""
    recipe = weights / RECIPE_NAME
    rescue, second_look = passes(json.loads(recipe.read_text()), recipe) if recipe.is_file() else (None, None)
    return OnnxDetector(
        weights / WEIGHTS_NAME,
        layout="v8",
        class_names=["person"],
        score_threshold=score_threshold,
        max_detections=MAX_DETECTIONS,
        rescue=rescue,
        second_look=second_look,
    )


def calibrate(weights: Path, frames: int, cache: Path | None = None) -> tuple[Calibration, float, dict[str, Any]]:
    """Fit the calibration and the threshold on calibration renders, the detector looking twice at close frames
    (the recipe's :class:`SecondLook`; the default one, then stored, when the recipe has no ``second_look``, and
    none when it says null); store them in the recipe."""
    recipe_path = weights / RECIPE_NAME
    recipe = json.loads(recipe_path.read_text())
    detector = raw_detector(weights)
    if "second_look" not in recipe:  # a recipe saying null keeps one pass
        detector.second_look = SecondLook()
        recipe["second_look"] = detector.second_look.model_dump()
    data = frames_for(CALIBRATION_SEED, frames, ALTITUDES_M, cache)
    m = evaluate(detector, data)
    threshold = best_threshold(m)
    counted = ~m.ignored
    calibration = Calibration.fit(m.scores[counted], m.hit[counted], m.long_px[counted], size_edges_px=SIZE_EDGES_PX)
    recipe["calibration"] = calibration.model_dump()
    recipe["score_threshold"] = round(threshold, 4)
    recipe["calibration_data"] = {"seed": CALIBRATION_SEED, "frames": frames, "detections": len(m.scores)}
    recipe_path.write_text(json.dumps(recipe, indent=2) + "\n")
    return calibration, threshold, recipe


def _fmt(x: float) -> str:
    return "–" if math.isnan(x) else f"{x:.3f}"


def _row(label: str, s: Scores) -> str:
    return f"| {label} | {s.truth} | {_fmt(s.precision)} | {_fmt(s.recall)} | {_fmt(s.ap50)} |"


def _training_line(recipe: dict[str, Any]) -> str:
    """One line of how a recipe's weights were trained (and, fine-tuned, from what)."""
    train, cfg = recipe.get("training", {}), recipe.get("config", {})
    line = (
        f"data seed {cfg.get('data_seed')}, {cfg.get('frames')} frames of {cfg.get('width_px')}×{cfg.get('height_px')}"
        f" at {cfg.get('altitudes_m')} m"
    )
    if cfg.get("extra_frames"):
        extra = cfg.get("extra_altitudes_m")
        line += f" and seed {cfg.get('extra_seed')}, {cfg.get('extra_frames')} frames at {extra} m"
    if cfg.get("neighbour_boxes"):
        line += ", the box taught at the two cells beside each centre cell too"
    stopped = {"steps": "a fixed step count" if cfg.get("steps") else "its epochs", "wall clock": "its wall-clock "
               "budget", "CPU time": "its CPU budget"}.get(str(train.get("stopped_by")))  # fmt: skip
    if stopped is not None:
        line += f", ended by {stopped}"
    return (
        f"{line}, crops of {cfg.get('crop_px')} px, {train.get('epochs_done')} epochs ({train.get('steps')} steps of "
        f"{cfg.get('batch')}, peak learning rate {cfg.get('learning_rate')}) in {train.get('seconds')} s of wall time "
        f"and {train.get('cpu_seconds', '?')} s of CPU time ({cfg.get('threads')} thread"
        f"{'' if cfg.get('threads') == 1 else 's'}) on a shared 2-core machine"
    )


def _description(recipe: dict[str, Any], threshold: float) -> list[str]:
    """The report's opening: the network, its training (and the weights it was fine-tuned from), quantisation,
    calibration and the test."""
    cfg = recipe.get("config", {})
    context = "stride 8, 16 and 32" if cfg.get("context32") else "stride 8 and 16"
    lines = [
        "A small single-class anchor-free centre-point network (a stem of two stride-2 3×3 convolutions to stride 4, "
        f"{context} context added back, `evaluation/detector/network.py`), trained on the CPU on frames "
        "rendered by `flight.sim.render` with exact labels (focal loss on a Gaussian centre heatmap, L1 and GIoU on "
        "the box), exported to ONNX in the YOLOv8 layout and run by `OnnxDetector` (`--detector ours`). Weights: "
        f"`agentic_core/perception/detectors/weights/person.onnx`, SHA-256 `{recipe['sha256']}`; recipe beside them "
        "(`person.json`).",
        "",
        f"- training: {_training_line(recipe)}",
    ]
    made = recipe.get("made")
    if isinstance(made, dict):
        steps = made.get("stages", {})
        named = {"train": "render and train"}
        each = ", ".join(
            f"{named.get(name, name)} {s.get('seconds', 0.0) / 60:.1f}" for name, s in steps.items() if name != "total"
        )
        total = steps.get("total", {})
        lines.insert(
            2,
            f"- made from nothing by one command, `{made.get('command')}`, in {total.get('seconds', 0.0) / 60:.1f} "
            f"min of wall time ({total.get('cpu_seconds', 0.0) / 60:.1f} CPU min) on a {made.get('cpus', '?')}-core "
            "machine (minutes: "
            f"{each}; "
            + (
                "a fixed step count, so the same command makes the same weights)"
                if recipe.get("config", {}).get("steps")
                else "training's wall-clock budget decides how many steps it takes)"
            ),
        )
    parent = recipe.get("parent")
    while isinstance(parent, dict):
        lines.append(f"  - fine-tuned from weights `{str(parent.get('sha256'))[:12]}…`: {_training_line(parent)}")
        parent = parent.get("parent")
    quantised = recipe.get("quantisation")
    if isinstance(quantised, dict):
        frames = quantised.get("calibration_frames", {})
        lines.append(
            f"- quantised to int8 (`python -m evaluation.detector.quantise`): {quantised.get('method')}; ranges from "
            f"{frames.get('count')} frames of seed {frames.get('seed')}; the float model's SHA-256 "
            f"`{quantised.get('float_sha256')}`. The numbers below are the int8 model's, the file a run loads"
        )
    refit = recipe.get("box_refit")
    if isinstance(refit, dict):
        data = refit.get("data", {})
        lines.append(
            f"- box rows refitted (`python -m evaluation.detector.box_refit`): {refit.get('method')}; "
            f"{refit.get('samples')} detections in {data.get('frames')} frames of seed {data.get('seed')} and "
            f"{data.get('extra_frames', 0)} of seed {data.get('extra_seed')}; the weights before it, SHA-256 "
            f"`{refit.get('before_sha256')}`"
        )
    rescue = recipe.get("rescue")
    if isinstance(rescue, dict):
        chosen, without, kept = rescue.get("chosen_on", {}), rescue.get("without", {}), rescue.get("with", {})
        lines.append(
            f"- crowded persons rescued (`python -m evaluation.detector.rescue_fit`, "
            "`agentic_core/perception/detectors/rescue.py`): a cell the 3×3 peak test removed is kept when it scores "
            f"at least {rescue.get('min_score')}, its box is at least {rescue.get('min_long_px')} px long and no "
            f"higher neighbour predicts a centre within {rescue.get('centre_ratio')} of their shorter sides; chosen "
            f"on {chosen.get('frames')} renders of seed {chosen.get('seed')} (best F1, precision at most "
            f"{chosen.get('max_precision_loss')} lower): F1 {without.get('f1', float('nan')):.3f} → "
            f"{kept.get('f1', float('nan')):.3f}, precision {without.get('precision', float('nan')):.3f} → "
            f"{kept.get('precision', float('nan')):.3f} there; the weights before it, SHA-256 "
            f"`{rescue.get('before_sha256')}` (the same network, the scores before the peak test added as an output)"
        )
    if recipe.get("second_look") is not None:
        look = SecondLook.model_validate(recipe["second_look"])
        reach = look.person_m * render_focal_px(TrainConfig().width_px) / look.from_person_px
        lines.append(
            "- a second look at close frames (`agentic_core/perception/detectors/second_look.py`): where a person "
            f"{look.person_m:g} m long would span at least {look.from_person_px:g} px (from {reach:.0f} m down "
            f"on this camera), the model runs again on the frame shifted by {look.shift_px} px (half a grid cell) "
            "and the two passes' boxes are merged by NMS, each person at the better score: where a person falls on "
            "the grid no longer decides whether a close look sees them. The rows under that height are with it; "
            "the calibration is fitted on what it gives"
        )
    return [
        *lines,
        f"- calibration and threshold: {recipe['calibration_data']['frames']} renders of seed {CALIBRATION_SEED}; "
        f"operating threshold (raw score, best F1 there) {threshold:.3f}",
        f"- held-out test: seed {TEST_SEED}, {TEST_FRAMES} frames per altitude; a detection is a hit at IoU ≥ 0.5 "
        "with a labelled person; precision counts every detection at the threshold, recall and AP@0.5 the "
        "persons named in the row",
        f"- persons seen less than {MIN_SEEN:g} (the share of their box in the image times the share of their drawn "
        "pixels no other person covers, exact from the renderer's drawing order) are ignored, as KITTI and COCO "
        "ignore heavily occluded and crowd boxes: not counted in recall (nor in the persons column), and a detection "
        "on one is neither a hit nor a false alarm; everyone else counts",
    ]


def write_report(
    weights: Path,
    docs: Path,
    calibration: Calibration,
    threshold: float,
    recipe: dict[str, Any],
    cache: Path | None = None,
) -> str:
    """Score the detector on held-out renders and write the Markdown report and the reliability diagram."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    detector, operating = raw_detector(weights), raw_detector(weights, threshold)
    by_altitude: list[str] = []
    by_pose: dict[str, list[str]] = {pose: [] for pose in POSES}
    all_scores: list[np.ndarray] = []
    all_hits: list[np.ndarray] = []
    all_long: list[np.ndarray] = []
    timings: list[float] = []
    lost: list[str] = []
    for altitude in REPORT_ALTITUDES_M:
        frames = frames_for(TEST_SEED, TEST_FRAMES, (altitude,), cache)
        m = evaluate(detector, frames)
        if altitude == DIAGNOSED[0]:
            lost = breakdown_lines(breakdown(detector, frames, threshold, DIAGNOSED[1]))
        timings.append(_detect_time(operating, frames))  # as a run uses it: at the threshold, not the floor
        by_altitude.append(_row(f"{altitude:g} m", scores_at(m, threshold, pose_masks(frames, None))))
        for pose in POSES:
            by_pose[pose].append(_row(f"{altitude:g} m", scores_at(m, threshold, pose_masks(frames, pose))))
        all_scores.append(m.scores[~m.ignored])
        all_hits.append(m.hit[~m.ignored])
        all_long.append(m.long_px[~m.ignored])
    scores, hits, long_px = np.concatenate(all_scores), np.concatenate(all_hits), np.concatenate(all_long)
    kept = scores >= threshold
    ece_raw = expected_calibration_error(scores[kept], hits[kept])
    calibrated = calibration.apply(scores, long_px)
    ece_cal = expected_calibration_error(calibrated[kept], hits[kept])
    fig, ax = plt.subplots(figsize=(5, 5), dpi=100)
    ax.plot([0, 1], [0, 1], color="grey", lw=0.8, ls="--", label="perfect")
    for conf, label in ((scores[kept], f"raw score (ECE {ece_raw:.3f})"),
                        (calibrated[kept], f"calibrated (ECE {ece_cal:.3f})")):  # fmt: skip
        r = reliability(conf, hits[kept], bins=10)
        ax.plot(r.confidence, r.frequency, marker="o", label=label)
    ax.set_xlabel("confidence")
    ax.set_ylabel("share that are persons")
    ax.set_title("Reliability on held-out renders (10–60 m)")
    ax.legend(loc="upper left")
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    fig.tight_layout()
    fig.savefig(docs / "detector_reliability.png")
    plt.close(fig)
    head = "| altitude | persons | precision | recall | AP@0.5 |\n|---|---|---|---|---|"
    lines = [
        "# Our person detector",
        "",
        "Generated by `python -m evaluation.detector.report`; do not edit by hand.",
        "",
        *_description(recipe, threshold),
        "",
        "## All persons, by altitude",
        "",
        head,
        *by_altitude,
        "",
        "## By pose",
        "",
        "Precision is over all detections (the detector does not tell poses apart); recall and AP are the pose's.",
    ]
    for pose in POSES:
        lines += ["", f"### {pose}", "", head, *by_pose[pose]]
    lines += [
        "",
        f"## Where {DIAGNOSED[1]} persons at {DIAGNOSED[0]:g} m are lost",
        "",
        f"Each {DIAGNOSED[1]} person counted at {DIAGNOSED[0]:g} m in one class, at the operating threshold "
        "(`python -m evaluation.detector.diagnose` for any pose and altitude): found; matched "
        "only under the threshold; a fitting box (IoU ≥ 0.5) matched to a neighbour; the best box at the threshold "
        "of the wrong size or place (IoU 0.3–0.5); missed.",
        "",
        *lost,
        "",
        "## Calibration",
        "",
        "The World Model's `conf` is the raw score through an isotonic calibration fitted on the calibration "
        "renders (stored in the recipe), one for each band of box sizes (the box's longer side): one raw score "
        "does not mean the same precision for a tiny box as for a large one. Expected calibration error (10 bins) "
        f"of detections at the threshold on the held-out renders: raw {ece_raw:.3f}, calibrated {ece_cal:.3f}.",
        "",
        "![reliability diagram](detector_reliability.png)",
        "",
        *_size_lines(scores[kept], hits[kept], long_px[kept], calibration),
        "",
        "## Time",
        "",
        f"Detect at the operating threshold (letterbox, ONNX Runtime on one thread, decode, NMS; twice on a close "
        f"frame) per 640×480 frame: mean {1000 * float(np.mean(timings)):.1f} ms over the altitudes' means "
        "(`benchmarks/detect_timing.py` and `benchmarks/pixel_pipeline.py` measure it in a run's setting).",
        "",
    ]
    text = "\n".join(lines)
    (docs / "detector.md").write_text(text)
    return text


def _size_lines(scores: np.ndarray, hits: np.ndarray, long_px: np.ndarray, calibration: Calibration) -> list[str]:
    """By size band, at the threshold on the held-out renders: the precision, and the mean confidence and the ECE
    with one map for all sizes and with the band's own."""
    one = Calibration(scores=calibration.scores, probs=calibration.probs)
    lines = [
        "| box's longer side | detections | precision | mean conf, one map | ECE | mean conf, by size | ECE |",
        "|---|---|---|---|---|---|---|",
    ]
    edges = [0.0, *calibration.size_edges_px, math.inf]
    bands = size_bands(calibration.size_edges_px, long_px)
    for k, (low, high) in enumerate(itertools.pairwise(edges)):
        inside = bands == k
        if not inside.any():
            continue
        label = f"{low:g}–{high:g} px" if math.isfinite(high) else f"{low:g} px and more"
        flat, sized = one.apply(scores[inside]), calibration.apply(scores[inside], long_px[inside])
        lines.append(
            f"| {label} | {int(inside.sum())} | {hits[inside].mean():.3f} | {flat.mean():.3f} | "
            f"{expected_calibration_error(flat, hits[inside]):.3f} | {sized.mean():.3f} | "
            f"{expected_calibration_error(sized, hits[inside]):.3f} |"
        )
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Calibrate, then report."""
    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.report", description=__doc__)
    parser.add_argument("--weights", type=Path, required=True, help="the folder of person.onnx and person.json")
    parser.add_argument("--docs", type=Path, default=Path("docs"))
    parser.add_argument("--calibration-frames", type=int, default=120)
    parser.add_argument("--cache", type=Path, help="a folder to keep the rendered frames in (read when there)")
    args = parser.parse_args(argv)
    calibration, threshold, recipe = calibrate(args.weights, args.calibration_frames, args.cache)
    print(f"threshold {threshold:.3f}; calibration with {len(calibration.scores)} knots", flush=True)
    args.docs.mkdir(parents=True, exist_ok=True)
    print(write_report(args.weights, args.docs, calibration, threshold, recipe, args.cache))
    return 0


if __name__ == "__main__":
    sys.exit(main())
