"""The swarm's ground side: sectors auctioned one each, work in priority order, one claim per casualty, a
verification only by another UAV's eyes (k of n), a delivery only by a UAV carrying a kit, a lost UAV's work moved,
and awards that were not the manager's refused and audited."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import pytest

from agentic_core.contracts.errors import AgenticUAVError
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.swarm import Point, SwarmMessage, UavState
from agentic_core.contracts.world_model import WorldModel
from agentic_core.swarm.coordinator import Member, SwarmCoordinator
from agentic_core.swarm.sectors import split
from agentic_core.swarm.signing import MemoryAudit, Refused, Sealer, SwarmKey

HOME = (21.4133, 39.8933)
AREA = [offset_position(*HOME, n, e) for n, e in ((0, -80), (200, -80), (200, 80), (0, 80))]


def _world(*people: tuple[str, float, float]) -> WorldModel:
    def pose(north: float, east: float) -> dict[str, float]:
        lat, lon = offset_position(*HOME, north, east)
        return {"north": north, "east": east, "down": 0.0, "lat": lat, "lon": lon, "alt": 0.0}

    objects = [{"id": i, "class": "person", "conf": 0.9, "pose": pose(n, e)} for i, n, e in people]
    return WorldModel.model_validate({"timestamp": 1.0, "ego_pose": pose(0, 0), "objects": objects})


@dataclass
class Uav:
    """A UAV a test moves and kills by hand."""

    name: str
    east: float
    payload: tuple[str, ...] = ()
    north: float = 0.0
    alive: bool = True
    sees: WorldModel | None = None
    log: list[dict[str, object]] = field(default_factory=list)

    def state(self) -> UavState:
        where = Point(north=self.north, east=self.east, alt=30.0)
        return UavState(uav_id=self.name, position=where, battery_pct=90.0, payload=self.payload)

    def member(self, layer: float) -> Member:
        return Member(self.name, self.state, layer, world=lambda: self.sees, alive=lambda: self.alive)


@pytest.fixture
def uavs() -> list[Uav]:
    return [Uav("uav-1", -30.0), Uav("uav-2", -10.0), Uav("uav-3", 10.0, ("medkit",)), Uav("uav-4", 30.0, ("medkit",))]


@pytest.fixture
def swarm(uavs: list[Uav]) -> Iterator[SwarmCoordinator]:
    log: list[dict[str, object]] = []
    coordinator = SwarmCoordinator(
        SwarmKey.generate("mina"), [u.member(30.0 + 10 * i) for i, u in enumerate(uavs)], split(AREA, 4, home=HOME),
        audit=MemoryAudit(), log=log.append, verify_k=2, bid_window_s=2.0,
    )  # fmt: skip
    coordinator.records = log  # type: ignore[attr-defined]
    yield coordinator
    coordinator.close()


def test_every_sector_goes_to_one_uav_and_every_uav_gets_one(swarm: SwarmCoordinator) -> None:
    awarded = swarm.allocate_sectors()
    assert sorted(awarded) == ["S1", "S2", "S3", "S4"]
    assert sorted(awarded.values()) == ["uav-1", "uav-2", "uav-3", "uav-4"]
    for sector, uav in awarded.items():
        task = swarm.next_task(uav)
        assert task["skill"] == "survey_sector" and task["id"] == f"survey:{sector}" and len(task["polygon"]) == 4
    rounds = [r for r in swarm.records if r["event"] == "round"]  # type: ignore[attr-defined]
    assert len(rounds) == 4 and all(len(r["bids"]) >= 1 for r in rounds)


def test_a_uav_is_told_to_hold_until_the_fleet_is_done(swarm: SwarmCoordinator) -> None:
    awarded = swarm.allocate_sectors()
    first, *others = sorted(awarded.items())
    swarm.task_done(first[1], f"survey:{first[0]}")
    assert swarm.next_task(first[1])["skill"] == "hold"
    for sector, uav in others:
        swarm.task_done(uav, f"survey:{sector}")
    assert swarm.next_task(first[1])["skill"] == "done"


def test_a_uav_cannot_report_work_it_does_not_hold(swarm: SwarmCoordinator) -> None:
    awarded = swarm.allocate_sectors()
    other = next(u for s, u in awarded.items() if s != "S1")
    with pytest.raises(AgenticUAVError, match="does not hold"):
        swarm.task_done(other, "survey:S1")
    assert swarm.coverage["S1"] == []


def test_one_claim_per_casualty_the_second_finder_is_told_who_answers(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    uavs[0].sees = _world(("P-3", 110.0, -30.0))
    uavs[1].sees = _world(("P-9", 112.0, -29.0))  # the same person, under the other UAV's own track id
    first = swarm.claim("uav-1", "P-3")
    second = swarm.claim("uav-2", "P-9")
    assert first == {"claimed": True, "casualty": "C1", "by": "uav-1"}
    assert second == {"claimed": False, "casualty": "C1", "by": "uav-1"}
    with pytest.raises(AgenticUAVError, match="sees no"):
        swarm.claim("uav-2", "P-404")


def test_verification_needs_another_uavs_eyes(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    swarm.allocate_sectors()
    uavs[0].sees = _world(("P-3", 110.0, -30.0))
    swarm.claim("uav-1", "P-3")
    looks = 0

    def another_uav_arrives() -> None:
        nonlocal looks
        looks += 1
        if looks == 3:
            verifier = swarm.manager.allocation.awarded["verify_casualty:uav-1:C1"]
            next(u for u in uavs if u.name == verifier).sees = _world(("P-77", 110.5, -30.5))

    result = swarm.verify("uav-1", "C1", timeout_s=1e9, wait=another_uav_arrives)
    verifier = result["seen_by"][1] if result["seen_by"][0] == "uav-1" else result["seen_by"][0]
    assert result["verified"] and verifier != "uav-1" and len(result["seen_by"]) == 2
    assert "uav-1" not in swarm.manager.allocation.rounds[-1]["bids"]  # the finder never bids to verify itself


def test_verification_times_out_on_the_simulated_clock(uavs: list[Uav]) -> None:
    now = [0.0]
    swarm = SwarmCoordinator(SwarmKey.generate("mina"), [u.member(30.0) for u in uavs], [], clock=lambda: now[0])
    try:
        uavs[0].sees = _world(("P-3", 110.0, -30.0))
        swarm.claim("uav-1", "P-3")

        def tick() -> None:
            now[0] += 10.0

        result = swarm.verify("uav-1", "C1", timeout_s=60.0, wait=tick)
        assert result == {"verified": False, "seen_by": ["uav-1"], "k": 2}
        assert now[0] == pytest.approx(60.0)
        with pytest.raises(AgenticUAVError, match="found by uav-1"):
            swarm.verify("uav-2", "C1", timeout_s=1.0, wait=tick)
    finally:
        swarm.close()


def test_the_kit_goes_to_the_nearest_uav_carrying_one(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    uavs[0].sees = _world(("P-3", 0.0, -30.0))
    swarm.claim("uav-1", "P-3")
    awarded = swarm.deliver("uav-1", "C1")
    assert awarded["awarded"] == "uav-3"  # 40 m away, uav-4 60 m; uav-1 and uav-2 are nearer but carry no kit
    task = swarm.next_task("uav-3")
    assert task["skill"] == "deliver_kit" and task["lat"] == pytest.approx(uavs[0].sees.objects[0].pose.lat)


def test_a_lost_uavs_sector_is_auctioned_again_and_flown_by_another(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    awarded = swarm.allocate_sectors()
    victim = awarded["S2"]
    next(u for u in uavs if u.name == victim).alive = False
    swarm.watch()
    heir = swarm.manager.allocation.awarded["survey:S2"]
    assert heir != victim and heir in {u.name for u in uavs}
    assert victim in swarm.failed
    tasks = [t.id for t in swarm.participants[heir].tasks.values()]
    assert "survey:S2" in tasks
    for sector, uav in awarded.items():  # the heir flies its own sector first (least covered), then S2
        if uav == heir:
            swarm.task_done(heir, f"survey:{sector}")
    assert swarm.next_task(heir)["id"] == "survey:S2"
    failed = [r for r in swarm.records if r["event"] == "failed"]  # type: ignore[attr-defined]
    assert failed == [{**failed[0], "uav": victim, "moved": ["survey:S2"]}]


def test_a_uav_that_went_home_with_nothing_left_is_not_lost(swarm: SwarmCoordinator, uavs: list[Uav]) -> None:
    awarded = swarm.allocate_sectors()
    for sector, name in awarded.items():
        swarm.task_done(name, f"survey:{sector}")
    for uav in uavs:
        uav.alive = False
    swarm.watch()
    assert swarm.failed == []


def _award_on_the_wire(swarm: SwarmCoordinator) -> tuple[str, SwarmMessage]:
    """A genuine award as it crossed to its winner (captured off the channel)."""
    seen: list[SwarmMessage] = []
    channel = swarm.channels["uav-3"]
    send = channel.send

    async def tap(message: SwarmMessage) -> SwarmMessage | None:
        seen.append(message)
        return await send(message)

    channel.send = tap  # type: ignore[method-assign]
    swarm.allocate_sectors()
    awards = [m for m in seen if m.kind == "award"]
    assert awards, "uav-3 won nothing"
    return "uav-3", awards[0]


def test_a_replayed_award_is_refused_and_audited(swarm: SwarmCoordinator) -> None:
    uav, award = _award_on_the_wire(swarm)
    with pytest.raises(Refused) as refused:
        swarm.guards[uav].parse(award.model_dump_json())
    assert refused.value.rejection.reason == "replayed"
    assert "replayed" in swarm.audit.reasons()  # type: ignore[attr-defined]


def test_a_forged_award_is_refused_and_audited(swarm: SwarmCoordinator) -> None:
    uav, award = _award_on_the_wire(swarm)
    body = {**award.body, "task": {**award.body["task"], "id": "survey:S9"}}
    forged = Sealer(SwarmKey.generate("mina"), "ground").seal("award", body, recipient=uav)  # the wrong key
    tampered = award.model_copy(update={"body": body, "nonce": "ab" * 16})  # the right signature, another text
    for message in (forged, tampered):
        with pytest.raises(Refused) as refused:
            swarm.guards[uav].parse(message.model_dump_json())
        assert refused.value.rejection.reason == "forged"
    assert swarm.audit.reasons().count("forged") == 2  # type: ignore[attr-defined]
    assert "survey:S9" not in swarm.participants[uav].tasks


def test_without_the_ground_the_live_uavs_share_out_the_open_work_by_consensus(
    swarm: SwarmCoordinator, uavs: list[Uav]
) -> None:
    awarded = swarm.allocate_sectors()
    done_sector = "S1"
    swarm.task_done(awarded[done_sector], f"survey:{done_sector}")
    victim = awarded["S3"]
    next(u for u in uavs if u.name == victim).alive = False
    shared = swarm.without_ground()
    assert sorted(shared) == ["survey:S2", "survey:S3", "survey:S4"]  # the open work, the done sector left alone
    assert victim not in shared.values()
    for task_id, uav in shared.items():
        assert swarm.manager.allocation.awarded[task_id] == uav
        holders = [u for u, p in swarm.participants.items() if task_id in p.tasks]
        assert holders == [uav]  # exactly one UAV holds each task, and next_task hands it out
    heir = shared["survey:S3"]
    assert "survey:S3" in {swarm.next_task(heir)["id"]} | {t for t in swarm.participants[heir].tasks}
    record = next(r for r in swarm.records if r["event"] == "consensus")  # type: ignore[attr-defined]
    assert record["agreed"] and record["unassigned"] == []
