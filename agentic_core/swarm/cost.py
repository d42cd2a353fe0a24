"""What a task costs a UAV, in seconds: flying there from where it is (or from its last task), the work on site,
and a penalty for a low battery; ``None`` when it cannot do it at all (no kit aboard, failed, or not enough battery
to get there and home with the reserve). Contract Net's bids are this cost.

>>> from agentic_core.contracts.swarm import Point, SwarmTask, UavState
>>> uav = UavState(uav_id="uav-1", position=Point(north=0, east=0, alt=30), battery_pct=100)
>>> task = SwarmTask(id="T-1", skill="survey_sector", where=Point(north=400, east=300, alt=30), work_s=60)
>>> round(task_cost(uav, task), 1)
122.5
>>> task_cost(uav, task.model_copy(update={"skill": "deliver_kit", "needs": "medkit"})) is None
True
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

from agentic_core.contracts.swarm import Point, SwarmTask, UavState


@dataclass(frozen=True)
class CostModel:
    """The numbers behind a bid: cruise speed, battery used per kilometre, the reserve kept, the penalty weight."""

    speed_mps: float = 8.0
    drain_pct_per_km: float = 4.0
    reserve_pct: float = 20.0
    battery_weight_s: float = 60.0
    """Seconds added for a flat battery (scaled by the fraction spent): keeps fresh UAVs ahead on near-ties."""


DEFAULT = CostModel()
HOME = Point(north=0, east=0)


def task_cost(
    uav: UavState,
    task: SwarmTask,
    *,
    committed: Sequence[SwarmTask] = (),
    home: Point = HOME,
    model: CostModel = DEFAULT,
) -> float | None:
    """Seconds for ``uav`` to do ``task`` after the tasks it has already ``committed`` to; None if it cannot."""
    if uav.status == "failed" or (task.needs is not None and not uav.has(task.needs)):
        return None
    legs = [uav.position, *(t.where for t in committed), task.where]
    flown_m = sum(a.distance_to(b) for a, b in pairwise(legs))
    needed_pct = (flown_m + task.where.horizontal_to(home)) / 1000.0 * model.drain_pct_per_km + model.reserve_pct
    if needed_pct > uav.battery_pct:
        return None
    work_s = sum(t.work_s for t in committed) + task.work_s
    spent = 1.0 - uav.battery_pct / 100.0
    return flown_m / model.speed_mps + work_s + model.battery_weight_s * spent


__all__ = ["DEFAULT", "CostModel", "task_cost"]
