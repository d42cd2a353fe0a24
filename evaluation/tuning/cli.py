"""``agentic-uav eval tune``: tune the position controller's horizontal gains by CMA-ES on short wind-gust flights,
then fly held-out gusts with the incumbent and the candidate and accept the candidate only if it is better,
significantly (the ``tune`` extra: ``pip install 'agentic-uavs[tune]'``).

    agentic-uav eval tune --generations 4 --popsize 6 --train 3 --held-out 8 --out runs/tune

Writes ``tune.json`` (the gains, the scores, the paired test and the verdict) and the held-out flights' telemetry
(``telemetry/*.jsonl``, the rows the costs were computed from) under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from agentic_core.contracts.errors import AgenticUAVError, option_problem, report_error
from flight.sim.controller import Gains

from .tuner import BOUNDS, judge, tune, tuned

PROG = "agentic-uav eval tune"
HELD_OUT_SEED = 10_000
"""Held-out gusts are drawn from seeds from here on, never used in training."""


class TuneSettings(BaseModel):
    """How much to fly: cheap by default (about a minute on two cores)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    generations: int = Field(default=4, ge=1, le=200)
    popsize: int = Field(default=6, ge=2, le=100)
    train: int = Field(default=3, ge=1, le=100, description="training flights per candidate")
    held_out: int = Field(default=8, ge=2, le=500, description="held-out flights for the acceptance test")
    alpha: float = Field(default=0.05, gt=0.0, lt=1.0)
    seed: int = Field(default=1, ge=0)


def run_tuning(settings: TuneSettings, out: Path | None, incumbent: Gains | None = None) -> dict[str, object]:
    """Tune, judge on held-out flights, and report (written to ``out/tune.json`` when given)."""
    base = incumbent or Gains()
    train = [settings.seed * 1000 + i for i in range(settings.train)]
    candidate, train_score = tune(base, train, generations=settings.generations, popsize=settings.popsize,
                                  seed=settings.seed + 1)  # fmt: skip
    held = range(HELD_OUT_SEED + settings.seed * 1000, HELD_OUT_SEED + settings.seed * 1000 + settings.held_out)
    verdict = judge(base, candidate, held, settings.alpha, record=out / "telemetry" if out else None)
    report: dict[str, object] = {
        "settings": settings.model_dump(),
        "bounds": {k: list(v) for k, v in BOUNDS.items()},
        "incumbent": tuned(base),
        "candidate": tuned(candidate),
        "train_score": train_score,
        "test": verdict.test.model_dump(mode="json"),
        "accepted": verdict.accepted,
        "verdict": verdict.line(),
        "gains": tuned(candidate if verdict.accepted else base),
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "tune.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return report


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog=PROG, description=(__doc__ or "").split("\n\n")[0])
    for name, default in TuneSettings().model_dump().items():
        parser.add_argument(f"--{name.replace('_', '-')}", type=type(default), default=default)
    parser.add_argument("--out", type=Path, default=Path("runs") / "tune")
    args = parser.parse_args(argv)
    try:
        settings = TuneSettings(**{k: getattr(args, k) for k in TuneSettings.model_fields})
    except ValidationError as exc:
        print(f"{PROG}: {option_problem(exc)}", file=sys.stderr)
        return 2
    try:
        report = run_tuning(settings, args.out)
    except AgenticUAVError as exc:
        return report_error(PROG, exc, sys.stderr)
    print(f"incumbent {report['incumbent']}\ncandidate {report['candidate']} (training score "
          f"{report['train_score']:.4g})\n{report['verdict']}\nwritten: {args.out / 'tune.json'}")  # fmt: skip
    return 0


__all__ = ["TuneSettings", "main", "run_tuning"]
