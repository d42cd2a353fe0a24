"""Our person detector made from nothing with one command, through every stage the shipped one went through:
render, train, quantise, refit the boxes, fit the crowd rescue, calibrate and report, each stage timed.

``python -m evaluation.detector.recipe --out DIR`` runs the stages in order (each one's own command, in this
process), each in a folder of its own under ``DIR``; the last, ``DIR/final``, holds ``person.onnx`` and
``person.json`` as a run loads them (the recipe gains a ``made`` entry with every stage's wall and CPU seconds), and
``DIR/docs`` the report. Training stops at ``--train-minutes`` of wall clock (the learning rate's schedule follows
the budget), so the whole recipe takes about seven minutes more than that on a 2-core machine; how many steps that
buys depends on the machine. ``--train-steps N`` trains exactly N steps instead, with no time budget: the same
N (and ``--threads``) make the same weights.

>>> stages("runs/det")[0].name, [s.name for s in stages("runs/det")][1:]
('train', ['quantise', 'box_refit', 'rescue_fit', 'report'])
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from .train import RECIPE_NAME

TRAIN_MINUTES = 19.0
"""Training's wall-clock budget: rendering before it (2 min) and the later stages (5 min) take about seven more."""

EXTRA_ALTITUDES_M = ("10", "12.5", "15", "17.5", "20", "25", "30")
"""The second data seed's altitudes: more frames where lying persons are smallest among the ones that matter."""


@dataclass(frozen=True)
class Stage:
    """One stage: its name, the module whose ``main`` runs it, and its arguments."""

    name: str
    module: str
    argv: tuple[str, ...]


def stages(
    out: Path | str, *, train_minutes: float = TRAIN_MINUTES, threads: int = 2, train_steps: int | None = None
) -> list[Stage]:
    """The stages that make the weights in ``out`` (each writes the folder the next one reads); ``train_steps``
    replaces the time budget with an exact step count."""
    root = Path(out)
    float_, int8, refit, final = (str(root / name) for name in ("float", "int8", "refit", "final"))
    budget = (
        ("--max-minutes", f"{train_minutes:g}", "--max-cpu-minutes", f"{train_minutes * threads:g}")
        if train_steps is None
        else ("--steps", str(train_steps))
    )
    train = (
        "--out", float_, "--context32", "--neighbour-boxes", "--extra-seed", "4", "--extra-frames", "800",
        "--extra-altitudes", *EXTRA_ALTITUDES_M, "--epochs", "60", "--learning-rate", "2e-3",
        "--threads", str(threads), *budget,
    )  # fmt: skip
    return [
        Stage("train", "evaluation.detector.train", train),
        Stage("quantise", "evaluation.detector.quantise", ("--src", float_, "--out", int8)),
        Stage("box_refit", "evaluation.detector.box_refit", ("--src", int8, "--out", refit)),
        Stage("rescue_fit", "evaluation.detector.rescue_fit", ("--src", refit, "--out", final)),
        Stage("report", "evaluation.detector.report", ("--weights", final, "--docs", str(root / "docs"))),
    ]


def run(plan: Sequence[Stage], final: Path, *, log: Callable[[str], None] = print) -> dict[str, dict[str, float]]:
    """Run ``plan`` in order; every stage's wall and CPU seconds, also written into ``final``'s recipe. A stage
    that fails stops the recipe with its exit status (a :class:`SystemExit`)."""
    import importlib

    made: dict[str, dict[str, float]] = {}
    for stage in plan:
        wall0, cpu0 = time.monotonic(), time.process_time()
        log(f"== {stage.name}: python -m {stage.module} {' '.join(stage.argv)}")
        status = importlib.import_module(stage.module).main(list(stage.argv))
        if status:
            raise SystemExit(status)
        made[stage.name] = {
            "seconds": round(time.monotonic() - wall0, 1),
            "cpu_seconds": round(time.process_time() - cpu0, 1),
        }
        log(f"== {stage.name}: {made[stage.name]['seconds']:.0f} s, {made[stage.name]['cpu_seconds']:.0f} CPU s")
    made["total"] = {key: round(sum(s[key] for s in made.values()), 1) for key in ("seconds", "cpu_seconds")}
    recipe_path = final / RECIPE_NAME
    recipe = json.loads(recipe_path.read_text())
    recipe["made"] = {"command": "python -m evaluation.detector.recipe", "cpus": os.cpu_count(), "stages": made}
    recipe_path.write_text(json.dumps(recipe, indent=2) + "\n")
    return made


def main(argv: Sequence[str] | None = None) -> int:
    """The recipe's command line."""
    parser = argparse.ArgumentParser(prog="python -m evaluation.detector.recipe", description=__doc__)
    parser.add_argument("--out", type=Path, required=True, help="folder for every stage's output (created)")
    parser.add_argument("--train-minutes", type=float, default=TRAIN_MINUTES, help="training's wall-clock budget")
    parser.add_argument(
        "--train-steps", type=int, help="train exactly this many steps instead (no time budget): reproducible"
    )
    parser.add_argument("--threads", type=int, default=2, help="torch threads for training")
    args = parser.parse_args(argv)
    if args.train_minutes <= 0 or args.threads < 1:
        parser.error("--train-minutes must be above 0 and --threads at least 1")
    if args.train_steps is not None and args.train_steps < 1:
        parser.error("--train-steps must be at least 1")
    args.out.mkdir(parents=True, exist_ok=True)
    plan = stages(args.out, train_minutes=args.train_minutes, threads=args.threads, train_steps=args.train_steps)
    made = run(plan, args.out / "final")
    total = made["total"]
    print(f"made {args.out / 'final'} in {total['seconds'] / 60:.1f} min ({total['cpu_seconds'] / 60:.1f} CPU min)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
