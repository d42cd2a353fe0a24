"""The swarm's ground side over A2A: every UAV serves its signed Agent Card (its live state) and its JSON-RPC
endpoint on 127.0.0.1, the Contract Net rounds are posted over HTTP, and a forged, replayed or foreign award posted
to a UAV's endpoint by anyone is refused there and audited; a lost UAV is not called and its sector moves."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Iterator

import pytest

from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.swarm import Point, SwarmMessage, UavState
from agentic_core.swarm.a2a_channel import A2AChannel
from agentic_core.swarm.a2a_client import A2APeer, PeerError
from agentic_core.swarm.card_signing import CardRejected
from agentic_core.swarm.coordinator import Member, SwarmCoordinator
from agentic_core.swarm.sectors import split
from agentic_core.swarm.signing import MemoryAudit, Sealer, SwarmKey

from .wire import tap_wire

HOME = (21.4133, 39.8933)
AREA = [offset_position(*HOME, n, e) for n, e in ((0, -80), (200, -80), (200, 80), (0, 80))]


class Uav:
    """A UAV a test moves and kills by hand."""

    def __init__(self, name: str, east: float) -> None:
        self.name, self.east, self.alive, self.battery = name, east, True, 90.0

    def state(self) -> UavState:
        return UavState(uav_id=self.name, position=Point(north=0, east=self.east, alt=30.0), battery_pct=self.battery)

    def member(self) -> Member:
        return Member(self.name, self.state, 30.0, alive=lambda: self.alive)


@pytest.fixture
def key() -> SwarmKey:
    return SwarmKey.generate("mina")


@pytest.fixture
def uavs() -> list[Uav]:
    return [Uav(f"uav-{i + 1}", -30.0 + 20 * i) for i in range(3)]


@pytest.fixture
def swarm(key: SwarmKey, uavs: list[Uav]) -> Iterator[SwarmCoordinator]:
    coordinator = SwarmCoordinator(
        key, [u.member() for u in uavs], split(AREA, 3, home=HOME), audit=MemoryAudit(), bid_window_s=2.0, a2a=True
    )
    yield coordinator
    coordinator.close()


async def _post(url: str, message: SwarmMessage) -> SwarmMessage | None:
    async with A2APeer(url) as peer:
        return await peer.send(message)


def test_every_uav_is_an_a2a_agent_and_the_auction_goes_over_http(
    swarm: SwarmCoordinator, key: SwarmKey, uavs: list[Uav]
) -> None:
    agents = swarm.agents()
    assert sorted(agents) == ["uav-1", "uav-2", "uav-3"]
    assert all(url.startswith("http://127.0.0.1:") for url in agents.values()) and len(set(agents.values())) == 3
    awarded = swarm.allocate_sectors()
    assert sorted(awarded.values()) == ["uav-1", "uav-2", "uav-3"]
    served = swarm.a2a_report()
    assert all(served[u]["requests"] >= 3 for u in agents)  # three calls for proposals each, and its award
    assert sum(s["requests"] for s in served.values()) == 3 * 3 + 3
    uavs[1].battery = 41.0  # the card says the state of now, signed afresh

    async def card_state() -> UavState:
        async with A2APeer(agents["uav-2"], card_key=key) as peer:
            return await peer.state()

    assert asyncio.run(card_state()).battery_pct == 41.0

    async def foreign_key() -> None:
        async with A2APeer(agents["uav-2"], card_key=SwarmKey.generate("elsewhere")) as peer:
            await peer.card()

    with pytest.raises(CardRejected):
        asyncio.run(foreign_key())


def test_a_forged_replayed_or_foreign_award_posted_over_http_is_refused_and_audited(swarm: SwarmCoordinator) -> None:
    wire = tap_wire(swarm)
    swarm.allocate_sectors()
    before = dict(swarm.manager.allocation.awarded)
    uav, award = next((u, m) for u, m in wire if m.kind == "award")
    url = swarm.agents()[uav]
    held = dict(swarm.participants[uav].tasks)
    forged = Sealer(SwarmKey.generate("mina"), "ground").seal("award", award.body, recipient=uav)
    impostor = Sealer(swarm.key, "uav-3" if uav != "uav-3" else "uav-1").seal(
        "award", award.body, recipient=uav, conversation=award.conversation
    )
    reasons = []
    for bad in (award, forged):
        with pytest.raises(PeerError) as refused:
            asyncio.run(_post(url, bad))
        reasons.append(refused.value.refused)
    reply = asyncio.run(_post(url, impostor))  # signed by a member, but only the manager awards
    assert reply is not None and reply.kind == "refuse"
    assert reasons == ["replayed", "forged"]
    audited = [(r.receiver, r.reason, r.kind) for r in swarm.audit.rejections]  # type: ignore[attr-defined]
    assert audited == [(uav, "replayed", "award"), (uav, "forged", "award"), (uav, "unauthorised", "award")]
    assert swarm.participants[uav].tasks == held and swarm.manager.allocation.awarded == before


def test_a_lost_uav_is_not_called_and_its_sector_moves_over_a2a(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    awarded = swarm.allocate_sectors()
    victim = awarded["S1"]
    next(u for u in uavs if u.name == victim).alive = False
    swarm.watch()
    heir = swarm.manager.allocation.awarded["survey:S1"]
    assert victim in swarm.failed and heir != victim
    before = swarm.a2a_report()[victim]["requests"]
    channel = swarm.channels[victim]
    assert isinstance(channel, A2AChannel) and not channel.alive
    swarm.allocate_sectors()
    assert swarm.a2a_report()[victim]["requests"] == before


def test_without_the_ground_the_uavs_agree_over_their_a2a_endpoints(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    awarded = swarm.allocate_sectors()
    sent = tap_wire(swarm)  # what the ground sends from now on: nothing
    now = [0.0]
    swarm.heartbeats.clock = lambda: now[0]  # the swarm's clock, moved by hand
    swarm.lose_ground("fault ground_link@t=60s")
    before = {u: a["requests"] for u, a in swarm.a2a_report().items()}
    victim = awarded["S2"]
    now[0] = swarm.heartbeats.timeout_s + 1.0  # the victim silent that long; the others' heartbeats heard
    for uav in (u.name for u in uavs if u.name != victim):
        swarm.heartbeats.beat(uav)
    swarm.watch()
    heir = swarm.manager.allocation.awarded["survey:S2"]
    assert heir != victim and victim in swarm.failed and sent == []
    after = swarm.a2a_report()
    live = [u for u in after if u != victim]
    assert after[victim]["requests"] == before[victim]  # the lost UAV hears nothing
    assert all(after[u]["requests"] > before[u] for u in live)  # each live UAV heard the other's bids over HTTP
    agent = swarm.participants[heir].consensus
    assert agent is not None and "survey:S2" in swarm.participants[heir].tasks

    other = next(u for u in live if u != heir)
    beliefs = dict(agent.beliefs)
    outbid = {"bids": {"survey:S2": 0.0}}  # a bid that would take the sector, from a stranger to the swarm
    forged = Sealer(SwarmKey.generate("mina"), other).seal("bid", outbid, recipient=heir, conversation="consensus")
    with pytest.raises(PeerError) as refused:
        asyncio.run(_post(swarm.agents()[heir], forged))
    assert refused.value.refused == "forged"
    assert agent.beliefs == beliefs
    assert [(r.receiver, r.reason, r.kind) for r in swarm.audit.rejections] == [(heir, "forged", "bid")]  # type: ignore[attr-defined]


def test_two_consensus_runs_at_once_do_not_mix_their_bids(swarm: SwarmCoordinator) -> None:
    swarm.allocate_sectors()
    swarm.lose_ground("fault ground_link@t=60s")
    results: list[dict[str, str]] = []
    runs = [threading.Thread(target=lambda: results.append(swarm.without_ground())) for _ in range(2)]
    for run in runs:
        run.start()
    for run in runs:
        run.join(timeout=60.0)
    assert len(results) == 2 and results[0] == results[1]  # the same fleet, the same tasks: the same agreement
    awarded = swarm.manager.allocation.awarded
    assert sorted(awarded) == ["survey:S1", "survey:S2", "survey:S3"] and awarded == results[0]
    for uav, participant in swarm.participants.items():  # each task held by its winner alone
        assert sorted(participant.tasks) == sorted(t for t, u in awarded.items() if u == uav)
