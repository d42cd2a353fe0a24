"""Contract Net: bids from the cost model, awards to the cheapest able bidder, deadlines that a silent member cannot
stretch, awards that cannot be forged, replayed or sent by a mere member, and re-allocation when a UAV dies."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable, Iterator

import pytest

from agentic_core.contracts.swarm import Point, SwarmMessage, SwarmTask, UavState
from agentic_core.swarm.a2a_client import A2APeer
from agentic_core.swarm.a2a_server import A2AServer
from agentic_core.swarm.contract_net import Channel, LocalChannel, Manager, Participant
from agentic_core.swarm.cost import task_cost
from agentic_core.swarm.optimal import optimality_gap
from agentic_core.swarm.signing import Guard, MemoryAudit, Refused, Sealer, SwarmKey


def _state(uav: str, north: float, east: float = 0.0, **more: object) -> UavState:
    return UavState.model_validate(
        {"uav_id": uav, "position": Point(north=north, east=east, alt=30), "battery_pct": 90, **more}
    )


class Fleet:
    """In-process members, each with its own guard and audit, and a manager that checks their replies."""

    def __init__(self, key: SwarmKey, states: list[UavState], *, window_s: float = 0.5) -> None:
        self.key = key
        self.states = {s.uav_id: s for s in states}
        self.audits = {s.uav_id: MemoryAudit() for s in states}
        self.guards = {s.uav_id: Guard(key, s.uav_id, audit=self.audits[s.uav_id]) for s in states}
        self.participants = {
            s.uav_id: Participant(
                Sealer(key, s.uav_id), self._reader(s.uav_id), manager="ground", guard=self.guards[s.uav_id]
            )
            for s in states
        }
        self.channels = {u: LocalChannel(p, self.guards[u]) for u, p in self.participants.items()}
        self.sent: list[SwarmMessage] = []
        self.manager = Manager(Sealer(key, "ground"), Guard(key, "ground"), self._recording(), bid_window_s=window_s)

    def _reader(self, uav: str):
        return lambda: self.states[uav]

    def _recording(self) -> dict[str, Channel]:
        fleet = self

        class Recording:
            def __init__(self, inner: LocalChannel) -> None:
                self.inner = inner

            async def send(self, message: SwarmMessage) -> SwarmMessage | None:
                fleet.sent.append(message)
                return await self.inner.send(message)

        return {u: Recording(c) for u, c in self.channels.items()}


def _tasks() -> list[SwarmTask]:
    return [
        SwarmTask(id="S-1", skill="survey_sector", where=Point(north=300, east=0, alt=30), work_s=120),
        SwarmTask(id="S-2", skill="survey_sector", where=Point(north=-300, east=0, alt=30), work_s=120),
        SwarmTask(id="S-3", skill="survey_sector", where=Point(north=0, east=300, alt=30), work_s=120),
        SwarmTask(id="K-1", skill="deliver_kit", where=Point(north=250, east=250, alt=30), needs="medkit"),
    ]


@pytest.fixture
def fleet(key: SwarmKey) -> Fleet:
    return Fleet(
        key,
        [_state("a", 280), _state("b", -280), _state("c", 0, 280), _state("d", -50, -50, payload=("medkit",))],
    )


def test_each_task_goes_to_the_cheapest_able_bidder_and_the_bids_are_the_cost_model(fleet: Fleet) -> None:
    allocation = asyncio.run(fleet.manager.allocate(_tasks()))
    assert allocation.awarded == {"S-1": "a", "S-2": "b", "S-3": "c", "K-1": "d"}  # only d carries a kit
    kit_round = next(r for r in allocation.rounds if r["task"] == "K-1")
    assert set(kit_round["bids"]) == {"d"}
    first = allocation.rounds[0]
    assert first["bids"] == {u: task_cost(fleet.states[u], _tasks()[0]) for u in "abcd"}
    assert fleet.participants["d"].tasks.keys() == {"K-1"}
    gap = optimality_gap(list(fleet.states.values()), _tasks(), allocation.awarded)
    assert gap.optimal == allocation.awarded and gap.relative == pytest.approx(0.0)


def test_a_second_task_is_priced_from_where_the_first_leaves_the_uav(key: SwarmKey) -> None:
    fleet = Fleet(key, [_state("a", 0)])
    near, far = (
        SwarmTask(id=i, skill="survey_sector", where=Point(north=n, east=0, alt=30))
        for i, n in [("N", 100), ("F", -100)]
    )
    allocation = asyncio.run(fleet.manager.allocate([near, far]))
    assert allocation.awarded == {"N": "a", "F": "a"}
    assert allocation.costs["F"] == pytest.approx(task_cost(fleet.states["a"], far, committed=[near]))
    assert allocation.costs["F"] > task_cost(fleet.states["a"], far)  # type: ignore[operator]


def test_a_silent_member_cannot_hold_a_round_past_its_deadline(fleet: Fleet) -> None:
    fleet.channels["a"].alive = False
    started = time.monotonic()
    allocation = asyncio.run(fleet.manager.allocate(_tasks()[:1]))
    took = time.monotonic() - started
    assert "a" in allocation.silent and allocation.awarded["S-1"] != "a"
    assert took < 0.5 * 2 + 2.0  # the bid window and one award, not forever


def test_a_task_nobody_can_do_is_reported_unassigned(key: SwarmKey) -> None:
    fleet = Fleet(key, [_state("a", 0)])
    kit = SwarmTask(id="K", skill="deliver_kit", where=Point(north=10, east=0, alt=30), needs="medkit")
    allocation = asyncio.run(fleet.manager.allocate([kit]))
    assert allocation.awarded == {} and allocation.unassigned == ["K"]


def _award(fleet: Fleet) -> SwarmMessage:
    return next(m for m in fleet.sent if m.kind == "award" and m.recipient == "d")


def test_a_replayed_award_is_refused_and_audited(fleet: Fleet) -> None:
    asyncio.run(fleet.manager.allocate(_tasks()))
    fleet.participants["d"].tasks.clear()  # as if it had finished: a replay must not hand it the task again
    with pytest.raises(Refused, match="replayed"):
        asyncio.run(fleet.channels["d"].send(_award(fleet)))
    assert fleet.participants["d"].tasks == {} and fleet.audits["d"].reasons() == ["replayed"]


def test_a_forged_award_is_refused_and_audited(fleet: Fleet) -> None:
    asyncio.run(fleet.manager.allocate(_tasks()))
    genuine = _award(fleet)
    stolen = genuine.model_copy(update={"body": {**genuine.body, "task": {**genuine.body["task"], "id": "K-9"}}})
    outsider = Sealer(SwarmKey.generate("mina"), "ground").seal(
        "award", genuine.body, recipient="d", conversation=genuine.conversation
    )
    for forged in (stolen, outsider):
        with pytest.raises(Refused, match="forged"):
            asyncio.run(fleet.channels["d"].send(forged))
    assert fleet.participants["d"].tasks.keys() == {"K-1"} and fleet.audits["d"].reasons() == ["forged", "forged"]


def test_an_award_signed_by_a_member_not_the_manager_is_refused_and_audited(fleet: Fleet) -> None:
    asyncio.run(fleet.manager.allocate(_tasks()))
    genuine = _award(fleet)
    rogue = Sealer(fleet.key, "a").seal(
        "award", {"task": {**genuine.body["task"], "id": "K-2"}}, recipient="d", conversation=genuine.conversation
    )
    reply = asyncio.run(fleet.channels["d"].send(rogue))
    assert reply is not None and reply.kind == "refuse"
    assert "K-2" not in fleet.participants["d"].tasks and fleet.audits["d"].reasons() == ["unauthorised"]


def test_an_award_for_a_round_it_did_not_bid_is_refused(fleet: Fleet) -> None:
    task = SwarmTask(id="X", skill="survey_sector", where=Point(north=0, east=0, alt=30)).model_dump(mode="json")
    award = Sealer(fleet.key, "ground").seal("award", {"task": task}, recipient="a", conversation="X#99")
    reply = asyncio.run(fleet.channels["a"].send(award))
    assert reply is not None and reply.kind == "refuse" and fleet.participants["a"].tasks == {}


def test_a_bid_claiming_another_bidder_is_ignored(fleet: Fleet) -> None:
    class Liar:
        async def send(self, message: SwarmMessage) -> SwarmMessage | None:
            if message.kind != "cfp":
                return None
            body = {"task_id": message.body["task"]["id"], "bidder": "a", "cost": 0.0}
            return Sealer(fleet.key, "b").seal("bid", body, recipient="ground", conversation=message.conversation)

    fleet.manager.members["b"] = Liar()
    allocation = asyncio.run(fleet.manager.allocate(_tasks()[:1]))
    assert allocation.rounds[0]["bids"].get("a") != 0.0 and "b" not in allocation.rounds[0]["bids"]


def test_a_reported_failure_re_allocates_the_members_tasks(fleet: Fleet) -> None:
    asyncio.run(fleet.manager.allocate(_tasks()))
    failure = fleet.participants["a"].report("S-1", done=False, detail="motor")
    moved = asyncio.run(fleet.manager.report(Guard(fleet.key, "ground").check(failure)))
    assert moved == ["S-1"] and fleet.manager.allocation.awarded["S-1"] in {"b", "c", "d"}
    assert "a" not in fleet.manager.allocation.awarded.values()


def _constant(state: UavState) -> Callable[[], UavState]:
    return lambda: state


def test_a_done_task_stays_done_and_only_its_holder_can_report_it(fleet: Fleet) -> None:
    asyncio.run(fleet.manager.allocate(_tasks()))
    guard = Guard(fleet.key, "ground")
    not_holder = fleet.participants["b"].report("S-1", done=True)
    assert asyncio.run(fleet.manager.report(guard.check(not_holder))) == []
    assert fleet.manager.allocation.done == set()
    asyncio.run(fleet.manager.report(guard.check(fleet.participants["a"].report("S-1", done=True))))
    assert fleet.manager.allocation.done == {"S-1"} and fleet.participants["a"].tasks == {}
    assert asyncio.run(fleet.manager.fail("a")) == []  # nothing left of a's to move
    assert fleet.manager.allocation.awarded["S-1"] == "a"


@pytest.fixture
def served(key: SwarmKey) -> Iterator[tuple[dict[str, A2AServer], dict[str, UavState]]]:
    states = {s.uav_id: s for s in (_state("a", 280), _state("b", -280), _state("c", 0, 280))}
    servers = {}
    try:
        for uav, state in states.items():
            participant = Participant(Sealer(key, uav), _constant(state), manager="ground")
            servers[uav] = A2AServer(participant, Guard(key, uav))
        yield servers, states
    finally:
        for server in servers.values():
            server.close()


def test_killing_a_bidder_over_a2a_re_allocates_its_task(
    served: tuple[dict[str, A2AServer], dict[str, UavState]], key: SwarmKey
) -> None:
    servers, _ = served
    guard = Guard(key, "ground")

    async def scenario() -> tuple[dict[str, str], list[str], dict[str, str]]:
        peers = {uav: A2APeer(server.url, guard=guard, timeout_s=1.0) for uav, server in servers.items()}
        manager = Manager(Sealer(key, "ground"), guard, peers, bid_window_s=1.0)
        try:
            first = dict((await manager.allocate(_tasks()[:3])).awarded)
            await asyncio.to_thread(servers["a"].close)
            moved = await manager.heartbeat()
            return first, moved, dict(manager.allocation.awarded)
        finally:
            for peer in peers.values():
                await peer.aclose()

    first, moved, after = asyncio.run(scenario())
    assert first == {"S-1": "a", "S-2": "b", "S-3": "c"}
    assert moved == ["S-1"] and after["S-1"] in {"b", "c"} and set(after) == set(first)
