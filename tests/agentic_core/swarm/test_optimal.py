"""The optimality gap: the greedy auction is never better than the optimal assignment over the same costs, and
the optimal assignment respects every UAV's capacity and ability."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.contracts.swarm import Point, SwarmTask, UavState
from agentic_core.swarm.contract_net import LocalChannel, Manager, Participant
from agentic_core.swarm.optimal import INFEASIBLE, cost_matrix, optimality_gap
from agentic_core.swarm.signing import Guard, Sealer, SwarmKey

KEY = SwarmKey("mina", b"k" * 32)
coordinate = st.floats(min_value=-800, max_value=800, allow_nan=False)


@st.composite
def instances(draw: st.DrawFn) -> tuple[list[UavState], list[SwarmTask]]:
    n_uavs = draw(st.integers(1, 5))
    uavs = [
        UavState(
            uav_id=f"u{i}",
            position=Point(north=draw(coordinate), east=draw(coordinate), alt=30),
            battery_pct=draw(st.floats(min_value=40, max_value=100)),
            payload=("medkit",) if draw(st.booleans()) else (),
        )
        for i in range(n_uavs)
    ]
    tasks = [
        SwarmTask(
            id=f"t{i}",
            skill="deliver_kit" if kit else "survey_sector",
            where=Point(north=draw(coordinate), east=draw(coordinate), alt=30),
            needs="medkit" if kit else None,
            work_s=draw(st.floats(min_value=0, max_value=300)),
        )
        for i, kit in enumerate(draw(st.lists(st.booleans(), min_size=1, max_size=n_uavs)))
    ]
    return uavs, tasks


def _constant(state: UavState) -> Callable[[], UavState]:
    return lambda: state


async def _greedy(uavs: list[UavState], tasks: list[SwarmTask]) -> dict[str, str]:
    members = {
        u.uav_id: LocalChannel(Participant(Sealer(KEY, u.uav_id), _constant(u), manager="g"), Guard(KEY, u.uav_id))
        for u in uavs
    }
    return (await Manager(Sealer(KEY, "g"), Guard(KEY, "g"), members, bid_window_s=5.0).allocate(tasks)).awarded


@settings(max_examples=40, deadline=None)
@given(instances())
def test_the_auction_is_never_better_than_optimal_and_optimal_respects_ability(
    instance: tuple[list[UavState], list[SwarmTask]],
) -> None:
    uavs, tasks = instance
    awarded = asyncio.run(_greedy(uavs, tasks))
    gap = optimality_gap(uavs, tasks, awarded)  # capacity: at least the busiest UAV's load in the auction
    assert gap.optimal_total <= gap.greedy + 1e-6 and gap.relative >= -1e-9
    load = max(list(awarded.values()).count(u.uav_id) for u in uavs)
    slots = max(load, math.ceil(len(tasks) / len(uavs)))
    assert all(list(gap.optimal.values()).count(u.uav_id) <= slots for u in uavs)
    matrix = cost_matrix(uavs, tasks)
    column = {u.uav_id: j for j, u in enumerate(uavs)}
    for i, task in enumerate(tasks):
        if task.id in awarded:  # someone can do it: so both the auction and the optimum chose someone able
            assert matrix[i, column[awarded[task.id]]] < INFEASIBLE
            assert matrix[i, column[gap.optimal[task.id]]] < INFEASIBLE
