"""CMA-ES over the position controller's horizontal gains, inside safe bounds, against the flights' costs; and the
acceptance rule: a candidate replaces the incumbent only if held-out wind-gust flights score better, significantly
(Wilcoxon signed-rank, paired by the gust seed, one-sided by the sign of the mean difference).

>>> judge(Gains(), Gains(), seeds=range(100, 103)).accepted  # no better than itself: rejected
False
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from agentic_core.contracts.extras import require
from evaluation.stats.paired import PairedResult, paired_test
from flight.sim.controller import Gains
from flight.sim.gains_file import TUNABLE

from .flights import TARGET, Costs, costs, fly, read_telemetry, write_telemetry

BOUNDS: dict[str, tuple[float, float]] = TUNABLE
"""The safe envelope of each tuned gain (outside it the F450 oscillates or crawls): the ranges a gains file may set."""


def gains_at(x: Sequence[float], base: Gains) -> Gains:
    """``base`` with the tuned gains set from ``x`` in [0, 1]⁴ (clipped to the bounds)."""
    values = {name: lo + (hi - lo) * float(np.clip(v, 0.0, 1.0)) for (name, (lo, hi)), v in zip(BOUNDS.items(), x,
              strict=True)}  # fmt: skip
    return replace(base, **values)


def unit(g: Gains) -> list[float]:
    """The tuned gains of ``g`` in [0, 1]⁴."""
    return [(getattr(g, name) - lo) / (hi - lo) for name, (lo, hi) in BOUNDS.items()]


def flight_costs(gains: Gains, seed: int, record: Path | None = None) -> Costs:
    """One flight's costs, from its telemetry (written to ``record`` and read back when given)."""
    rows = fly(gains, seed)
    if record is not None:
        record.parent.mkdir(parents=True, exist_ok=True)
        write_telemetry(rows, record)
        rows = read_telemetry(record)
    return costs(rows, TARGET, start_s=rows[0].time_s)


def scores(gains: Gains, seeds: Iterable[int], record: Path | None = None, tag: str = "candidate") -> list[float]:
    """Per-flight score of ``gains`` on the gusts of each seed (:meth:`Costs.score`: lower is better)."""
    return [flight_costs(gains, seed, record / f"{tag}-{seed}.jsonl" if record else None).score() for seed in seeds]


@dataclass(frozen=True)
class Verdict:
    """The acceptance rule's answer, with the evidence."""

    accepted: bool
    candidate: Gains
    incumbent: Gains
    test: PairedResult
    alpha: float

    def line(self) -> str:
        said = "accepted" if self.accepted else "rejected"
        return f"{said}: {self.test.line()} (accept when lower and p < {self.alpha:g})"


def judge(incumbent: Gains, candidate: Gains, seeds: Iterable[int], alpha: float = 0.05,
          record: Path | None = None) -> Verdict:  # fmt: skip
    """Fly both on the held-out gusts ``seeds``; accept the candidate only if it scores lower, significantly."""
    seeds = list(seeds)
    before, after = scores(incumbent, seeds, record, "incumbent"), scores(candidate, seeds, record, "candidate")
    test = paired_test("incumbent", before, "candidate", after)
    accepted = test.mean_difference < 0 and test.significant(alpha)
    return Verdict(accepted, candidate, incumbent, test, alpha)


def tune(incumbent: Gains, train: Sequence[int], *, generations: int = 4, popsize: int = 6, seed: int = 1,
         sigma: float = 0.2) -> tuple[Gains, float]:  # fmt: skip
    """CMA-ES from the incumbent, over the training gusts: the best candidate found and its mean score."""
    cma = require("cma", "tune")
    es = cma.CMAEvolutionStrategy(unit(incumbent), sigma, {"bounds": [0.0, 1.0], "popsize": popsize,
                                                            "seed": seed, "verbose": -9})  # fmt: skip
    best, best_score = incumbent, float(np.mean(scores(incumbent, train)))
    for _ in range(generations):
        xs = es.ask()
        values = [float(np.mean(scores(gains_at(x, incumbent), train))) for x in xs]
        es.tell(xs, values)
        i = int(np.argmin(values))
        if values[i] < best_score:
            best, best_score = gains_at(xs[i], incumbent), values[i]
    return best, best_score


def tuned(g: Gains) -> dict[str, float]:
    """The tuned gains of ``g``, by name."""
    return {f.name: getattr(g, f.name) for f in fields(g) if f.name in BOUNDS}


__all__ = ["BOUNDS", "Verdict", "gains_at", "judge", "scores", "tune", "tuned", "unit"]
