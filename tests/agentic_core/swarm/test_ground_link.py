"""The ground link lost mid-mission: the ground is called no more, and what is left — the open sectors, a lost
UAV's work, a verification, a delivery — is settled among the live UAVs by consensus over their own signed messages,
each decision in the log; a finder never verifies its own find, only a UAV with a kit delivers one."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agentic_core.cli import main
from agentic_core.contracts.errors import InputError
from agentic_core.contracts.swarm import SwarmMessage
from agentic_core.run.swarm_faults import ground_link_lost_at
from agentic_core.swarm.coordinator import SwarmCoordinator
from agentic_core.swarm.sectors import split
from agentic_core.swarm.signing import MemoryAudit, SwarmKey
from tests.agentic_core.swarm.test_coordinator import AREA, HOME, Uav, _world


@pytest.fixture
def uavs() -> list[Uav]:
    return [Uav("uav-1", -30.0), Uav("uav-2", -10.0), Uav("uav-3", 10.0, ("medkit",)), Uav("uav-4", 30.0, ("medkit",))]


@pytest.fixture
def swarm(uavs: list[Uav]) -> Iterator[SwarmCoordinator]:
    log: list[dict[str, Any]] = []
    now = [0.0]
    coordinator = SwarmCoordinator(
        SwarmKey.generate("mina"), [u.member(30.0 + 10 * i) for i, u in enumerate(uavs)], split(AREA, 4, home=HOME),
        audit=MemoryAudit(), log=log.append, verify_k=2, bid_window_s=2.0, clock=lambda: now[0],
    )  # fmt: skip
    coordinator.records = log  # type: ignore[attr-defined]
    coordinator.now = now  # type: ignore[attr-defined]
    yield coordinator
    coordinator.close()


def _tap_ground(swarm: SwarmCoordinator) -> list[SwarmMessage]:
    """Every message the ground sends from now on."""
    sent: list[SwarmMessage] = []
    for channel in swarm.channels.values():
        send = channel.send

        async def tap(message: SwarmMessage, send: Any = send) -> SwarmMessage | None:
            sent.append(message)
            reply: SwarmMessage | None = await send(message)
            return reply

        channel.send = tap  # type: ignore[method-assign]
    return sent


def _events(swarm: SwarmCoordinator, kind: str) -> list[dict[str, Any]]:
    return [r for r in swarm.records if r["event"] == kind]  # type: ignore[attr-defined]


def test_after_the_ground_link_is_lost_everything_is_settled_by_consensus(
    swarm: SwarmCoordinator, uavs: list[Uav]
) -> None:
    awarded = swarm.allocate_sectors()
    swarm.task_done(awarded["S1"], "survey:S1")
    victim = awarded["S3"]
    next(u for u in uavs if u.name == victim).alive = False  # lost before the ground: nobody holds S3 now
    swarm.manager.allocation.awarded.pop("survey:S3")
    rounds = len(swarm.manager.allocation.rounds)
    sent = _tap_ground(swarm)
    swarm.now[0] = 61.5  # type: ignore[attr-defined]
    moved = swarm.lose_ground("fault ground_link@t=60s")
    assert swarm.lose_ground("again") == {}  # once
    (lost,) = _events(swarm, "ground_link_lost")
    assert lost["why"] == "fault ground_link@t=60s" and lost["sim_t"] == 61.5 and swarm.ground_lost_at == 61.5
    assert lost["kept"] == {f"survey:{s}": awarded[s] for s in ("S2", "S4")}  # a live UAV keeps what it flies
    assert lost["orphans"] == ["survey:S3"] and list(moved) == ["survey:S3"] and moved["survey:S3"] != victim
    (first,) = _events(swarm, "consensus")
    assert first["agreed"] and first["awarded"] == moved and victim not in first["among"]
    assert "survey:S3" in swarm.participants[moved["survey:S3"]].tasks

    heir = awarded["S2"]  # a UAV lost without the ground (its heartbeats stop): its work moves by consensus too
    live = [u.name for u in uavs if u.name not in (victim, heir)]
    while swarm.now[0] <= 61.5 + swarm.heartbeats.timeout_s + 1.0:  # type: ignore[attr-defined]
        swarm.watch()
        assert heir not in swarm.failed or swarm.now[0] > 61.5 + swarm.heartbeats.timeout_s  # type: ignore[attr-defined]
        swarm.now[0] += 1.0  # type: ignore[attr-defined]
        for uav in live:
            swarm.heartbeats.beat(uav)
    swarm.watch()
    assert heir in swarm.failed and swarm.manager.allocation.awarded["survey:S2"] not in (heir, victim)
    again = _events(swarm, "consensus")[-1]
    assert again["tasks"] == ["survey:S2"] and heir not in again["among"]
    lost_uavs = (victim, heir)

    finder = next(u for u in uavs if u.name not in lost_uavs)
    finder.sees = _world(("P-3", 110.0, finder.east))
    swarm.claim(finder.name, "P-3")
    result = swarm.verify(finder.name, "C1", timeout_s=0.0, wait=lambda: None)
    assert result["verified"] is False  # nobody else saw it in no time; but the look was allocated
    verify = _events(swarm, "consensus")[-1]
    assert list(verify["tasks"]) == [f"verify_casualty:{finder.name}:C1"] and finder.name not in verify["among"]
    delivery = swarm.deliver(finder.name, "C1")
    medics = {u.name for u in uavs if u.payload} - set(lost_uavs)
    assert delivery["awarded"] in medics and delivery["cost"] > 0
    swarm.task_done(delivery["awarded"], f"deliver_kit:{finder.name}:C1")
    assert f"deliver_kit:{finder.name}:C1" in swarm.manager.allocation.done
    assert sent == [] and len(swarm.manager.allocation.rounds) == rounds  # the ground was never called again
    assert not _events(swarm, "round")[rounds:]


def test_a_swarm_fault_is_ground_link_at_a_time(capsys: pytest.CaptureFixture[str]) -> None:
    assert ground_link_lost_at(["ground_link@t=12.5s"]) == 12.5
    for bad in (["gps_loss@t=5s"], ["ground_link@S1"], ["ground_link@t=5s", "ground_link@t=9s"], ["ground_link"]):
        with pytest.raises(InputError, match="--fault"):
            ground_link_lost_at(bad)
    code = main(["swarm", "run", "missions/hajj_swarm.yaml", "--fault", "link_loss@t=5s"])
    err = capsys.readouterr().err
    assert code == 2 and "link_loss@t=5s" in err and "ground_link@t=SECONDS" in err and "Traceback" not in err
