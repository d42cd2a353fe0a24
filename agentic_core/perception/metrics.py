"""How good the tracks are against ground truth: CLEAR-MOT style scoring, frame by frame.

Each frame, the ground-truth objects in view are matched one-to-one to the hypotheses (tracks) within
``max_distance_m``: first the pairs matched in the previous frame that are still close enough (so an identity is
not counted as switched merely because another track came nearer), then the rest by the Hungarian method on
distance. Counted over a run:

* **position RMSE** over matched pairs (m);
* **identity switches**: a ground-truth object matched to a different track than the last time it was matched;
* **recall**: matched / ground-truth object-frames; **precision**: matched / hypothesis-frames;
* **MOTA** ``1 - (misses + false tracks + switches) / ground-truth object-frames``.

Only the evaluation reads ground truth: the tracks are scored, never told.

>>> score = TrackingScore(max_distance_m=1.0)
>>> score.add({"a": (0.0, 0.0), "b": (5.0, 0.0)}, {"P-01": (0.1, 0.0), "P-02": (5.0, 0.2)})
{'a': 'P-01', 'b': 'P-02'}
>>> score.add({"a": (0.0, 0.0), "b": (5.0, 0.0)}, {"P-03": (0.0, 0.1), "P-02": (9.0, 0.0)})  # a: new id; b: lost
{'a': 'P-03'}
>>> score.id_switches, round(score.recall, 2), round(score.rmse_m, 3)
(1, 0.75, 0.141)
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from scipy.optimize import linear_sum_assignment

Point = tuple[float, float]


class TrackingScore:
    """Accumulates the CLEAR-MOT counts over frames (see the module docs); read the properties at the end."""

    def __init__(self, max_distance_m: float = 1.0) -> None:
        self.max_distance_m = max_distance_m
        self.frames = 0
        self.truth_count = 0
        self.hypothesis_count = 0
        self.matches = 0
        self.id_switches = 0
        self.squared_error = 0.0
        self._last: dict[str, str] = {}  # truth id -> the track it was last matched to

    def add(self, truth: Mapping[str, Point], hypotheses: Mapping[str, Point]) -> dict[str, str]:
        """Score one frame (ids to north/east positions); returns this frame's matches, truth id to track id."""
        self.frames += 1
        self.truth_count += len(truth)
        self.hypothesis_count += len(hypotheses)
        gate = self.max_distance_m
        matched: dict[str, str] = {}
        taken: set[str] = set()
        for t_id, h_id in self._last.items():  # keep earlier correspondences that still hold, one track each
            kept = t_id in truth and h_id in hypotheses and h_id not in taken
            if kept and _dist(truth[t_id], hypotheses[h_id]) <= gate:
                matched[t_id] = h_id
                taken.add(h_id)
        t_left = [t for t in truth if t not in matched]
        h_left = [h for h in hypotheses if h not in taken]
        if t_left and h_left:
            tp = np.array([truth[t] for t in t_left], dtype=float)
            hp = np.array([hypotheses[h] for h in h_left], dtype=float)
            cost = np.hypot(tp[:, None, 0] - hp[None, :, 0], tp[:, None, 1] - hp[None, :, 1])
            cost = np.where(cost <= gate, cost, 1e9)
            rows, cols = linear_sum_assignment(cost)
            for r, c in zip(rows, cols, strict=True):
                if cost[r, c] <= gate:
                    matched[t_left[r]] = h_left[c]
        for t_id, h_id in matched.items():
            previous = self._last.get(t_id)
            if previous is not None and previous != h_id:
                self.id_switches += 1
            self._last[t_id] = h_id
            self.squared_error += _dist(truth[t_id], hypotheses[h_id]) ** 2
        self.matches += len(matched)
        return matched

    @property
    def rmse_m(self) -> float:
        return math.sqrt(self.squared_error / self.matches) if self.matches else math.nan

    @property
    def recall(self) -> float:
        return self.matches / self.truth_count if self.truth_count else math.nan

    @property
    def precision(self) -> float:
        return self.matches / self.hypothesis_count if self.hypothesis_count else math.nan

    @property
    def mota(self) -> float:
        if not self.truth_count:
            return math.nan
        misses = self.truth_count - self.matches
        false_tracks = self.hypothesis_count - self.matches
        return 1.0 - (misses + false_tracks + self.id_switches) / self.truth_count

    @property
    def id_switches_per_1000(self) -> float:
        """Identity switches per thousand matched object-frames (comparable across runs of any length)."""
        return 1000.0 * self.id_switches / self.matches if self.matches else math.nan

    def summary(self) -> str:
        """One line for test output and reports."""
        return (
            f"frames {self.frames}, truth {self.truth_count}, rmse {self.rmse_m:.3f} m, id switches "
            f"{self.id_switches} ({self.id_switches_per_1000:.2f}/1000), recall {self.recall:.3f}, "
            f"precision {self.precision:.3f}, MOTA {self.mota:.3f}"
        )


def _dist(a: Point, b: Point) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])
