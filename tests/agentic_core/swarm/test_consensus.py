"""The decentralised fallback: with no manager, the UAVs agree among themselves who does what — every task to
exactly one UAV, the same answer in every UAV's view, no better than a UAV that can do it, no worse for a liar's
forged message — and with one UAV per task it is the optimal assignment."""

from __future__ import annotations

import random

import pytest

from agentic_core.contracts.swarm import Point, SwarmMessage, SwarmTask, UavState
from agentic_core.swarm.consensus import ConsensusAgent, agree
from agentic_core.swarm.optimal import optimality_gap
from agentic_core.swarm.signing import Guard, MemoryAudit, Sealer, SwarmKey


def _fleet(key: SwarmKey, states: list[UavState], audit: MemoryAudit) -> dict[str, ConsensusAgent]:
    def agent(state: UavState) -> ConsensusAgent:
        return ConsensusAgent(Sealer(key, state.uav_id), Guard(key, state.uav_id, audit=audit), lambda: state)

    return {s.uav_id: agent(s) for s in states}


def _mesh(names: list[str]) -> dict[str, list[str]]:
    return {n: [m for m in names if m != n] for n in names}


def _problem(seed: int, n_uavs: int, n_tasks: int) -> tuple[list[UavState], list[SwarmTask]]:
    rng = random.Random(seed)
    uavs = [
        UavState(
            uav_id=f"uav-{i + 1}",
            position=Point(north=rng.uniform(-300, 300), east=rng.uniform(-300, 300), alt=30),
            battery_pct=rng.uniform(60, 100),
            payload=("medkit",) if i % 2 else (),
        )
        for i in range(n_uavs)
    ]
    tasks = [
        SwarmTask(
            id=f"T-{j + 1}",
            skill="deliver_kit" if j % 4 == 0 else "survey_sector",
            where=Point(north=rng.uniform(-300, 300), east=rng.uniform(-300, 300), alt=30),
            needs="medkit" if j % 4 == 0 else None,
            work_s=rng.uniform(10, 60),
        )
        for j in range(n_tasks)
    ]
    return uavs, tasks


@pytest.mark.parametrize("seed", range(8))
def test_every_task_goes_to_exactly_one_able_uav_and_all_agree(seed: int) -> None:
    key, audit = SwarmKey.generate("mina"), MemoryAudit()
    uavs, tasks = _problem(seed, 5, 9)
    agents = _fleet(key, uavs, audit)
    result = agree(agents, tasks, links=_mesh(list(agents)))
    assert result.agreed and result.unassigned == []
    held = [t for bundle in result.bundles.values() for t in bundle]
    assert sorted(held) == sorted(t.id for t in tasks)  # no task twice, none dropped
    kit_carriers = {u.uav_id for u in uavs if u.has("medkit")}
    assert all(result.assignment[t.id] in kit_carriers for t in tasks if t.needs == "medkit")
    assert audit.rejections == []


@pytest.mark.parametrize("seed", range(6))
def test_one_uav_per_task_is_the_optimal_assignment_when_costs_are_first_legs(seed: int) -> None:
    key = SwarmKey.generate("mina")
    uavs, tasks = _problem(seed, 4, 4)
    tasks = [t.model_copy(update={"needs": None, "skill": "survey_sector"}) for t in tasks]
    agents = _fleet(key, uavs, MemoryAudit())
    for agent in agents.values():
        agent.max_bundle = 1
    result = agree(agents, tasks, links=_mesh(list(agents)))
    assert result.agreed and result.unassigned == []
    gap = optimality_gap(uavs, tasks, result.assignment)
    assert gap.greedy <= gap.optimal_total * 1.5 + 1e-6  # a greedy auction: near, not always at, the optimum


def test_a_forged_or_replayed_consensus_message_is_refused_and_changes_nothing() -> None:
    key, audit = SwarmKey.generate("mina"), MemoryAudit()
    uavs, tasks = _problem(3, 3, 5)
    honest = agree(_fleet(key, uavs, MemoryAudit()), tasks, links=_mesh([u.uav_id for u in uavs]))
    liar = Sealer(SwarmKey.generate("mina"), "uav-1")  # the right name, not the swarm's key
    sent: list[str] = []

    def tamper(to: str, message: SwarmMessage) -> str:
        sent.append(message.model_dump_json())
        if len(sent) == 1:  # the first message on the wire: a liar's, claiming every task for nothing
            forged = liar.seal("bid", {"bids": {t.id: 0.0 for t in tasks}}, recipient=to, conversation="consensus")
            return forged.model_dump_json()
        return sent[-1]

    agents = _fleet(key, uavs, audit)
    attacked = agree(agents, tasks, links=_mesh(list(agents)), deliver=tamper)
    assert attacked.assignment == honest.assignment and attacked.agreed
    replay = sent[1]  # a genuine message, delivered once already
    recipient = SwarmMessage.model_validate_json(replay).recipient
    assert recipient is not None and not agents[recipient].hear(replay)
    assert sorted(audit.reasons()) == ["forged", "replayed"]


def test_no_uav_can_take_a_task_nobody_can_do() -> None:
    key = SwarmKey.generate("mina")
    state = UavState(uav_id="uav-1", position=Point(north=0, east=0, alt=30), battery_pct=90)
    task = SwarmTask(id="K", skill="deliver_kit", where=Point(north=10, east=0), needs="medkit")
    result = agree(_fleet(key, [state], MemoryAudit()), [task], links={"uav-1": []})
    assert result.unassigned == ["K"] and result.assignment == {}
