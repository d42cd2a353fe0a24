"""How far Contract Net's greedy auction is from the best assignment: the optimal one by
``scipy.optimize.linear_sum_assignment`` over the same costs, each UAV taking at most ``capacity`` tasks.

Both are priced with each task's cost from the UAV's starting state (its first leg), the assignment relaxation:
exact when each UAV takes one task, a lower bound's proxy when tasks queue.

>>> from agentic_core.contracts.swarm import Point, SwarmTask, UavState
>>> def at(north: float) -> Point:
...     return Point(north=north, east=0, alt=30)
>>> uavs = [UavState(uav_id=n, position=at(x), battery_pct=90) for n, x in [("a", 0), ("b", 100)]]
>>> tasks = [SwarmTask(id=t, skill="survey_sector", where=at(x)) for t, x in [("T1", 60), ("T2", 140)]]
>>> gap = optimality_gap(uavs, tasks, {"T1": "b", "T2": "a"})
>>> gap.optimal, round(gap.relative, 2)
({'T1': 'a', 'T2': 'b'}, 0.41)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from agentic_core.contracts.swarm import SwarmTask, UavState
from agentic_core.swarm.cost import DEFAULT, CostModel, task_cost

INFEASIBLE = 1e9
"""The cost that stands for "cannot": large enough that any feasible assignment beats it."""


@dataclass(frozen=True)
class Gap:
    """The greedy allocation's total cost against the optimal one's, and the optimal assignment itself."""

    greedy: float
    optimal_total: float
    optimal: dict[str, str]

    @property
    def relative(self) -> float:
        """(greedy - optimal) / optimal; 0 when both are 0."""
        return 0.0 if self.optimal_total == 0 else (self.greedy - self.optimal_total) / self.optimal_total


def cost_matrix(uavs: Sequence[UavState], tasks: Sequence[SwarmTask], model: CostModel = DEFAULT) -> np.ndarray:
    """tasks × uavs, seconds; :data:`INFEASIBLE` where a UAV cannot do a task."""
    matrix = np.full((len(tasks), len(uavs)), INFEASIBLE)
    for i, task in enumerate(tasks):
        for j, uav in enumerate(uavs):
            cost = task_cost(uav, task, model=model)
            if cost is not None:
                matrix[i, j] = cost
    return matrix


def optimality_gap(
    uavs: Sequence[UavState],
    tasks: Sequence[SwarmTask],
    awarded: Mapping[str, str],
    *,
    capacity: int | None = None,
    model: CostModel = DEFAULT,
) -> Gap:
    """The gap of ``awarded`` (task id → uav id) to the optimal assignment, each UAV taking at most ``capacity``
    tasks (by default as many as the busiest UAV of ``awarded``, at least ceil(tasks / uavs))."""
    if not uavs or not tasks:
        return Gap(0.0, 0.0, {})
    load = max((list(awarded.values()).count(u.uav_id) for u in uavs), default=0)
    slots = capacity or max(load, math.ceil(len(tasks) / len(uavs)))
    matrix = cost_matrix(uavs, tasks, model)
    rows, cols = linear_sum_assignment(np.tile(matrix, (1, slots)))
    optimal = {tasks[r].id: uavs[c % len(uavs)].uav_id for r, c in zip(rows, cols, strict=True)}
    column = {u.uav_id: j for j, u in enumerate(uavs)}
    index = {t.id: i for i, t in enumerate(tasks)}
    greedy = sum(float(matrix[index[t], column[u]]) for t, u in awarded.items() if t in index and u in column)
    best = sum(float(matrix[r, c % len(uavs)]) for r, c in zip(rows, cols, strict=True) if tasks[r].id in awarded)
    return Gap(greedy, best, optimal)


__all__ = ["INFEASIBLE", "Gap", "cost_matrix", "optimality_gap"]
