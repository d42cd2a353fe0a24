"""Without the ground, a UAV lives as long as its peers hear its signed heartbeats: one that falls silent is failed
after the timeout and its work moves by consensus, even while shared memory still says its vehicle is fine; a
heartbeat forged for it, or one of its own replayed, keeps nobody alive and is refused and audited."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from agentic_core.contracts.swarm_plan import Heartbeat
from agentic_core.swarm.coordinator import SwarmCoordinator
from agentic_core.swarm.sectors import split
from agentic_core.swarm.signing import MemoryAudit, Sealer, SwarmKey
from tests.agentic_core.swarm.test_coordinator import AREA, HOME, Uav

TIMEOUT_S = 5.0


@pytest.fixture
def swarm() -> Iterator[SwarmCoordinator]:
    uavs = [Uav("uav-1", -20.0), Uav("uav-2", 0.0), Uav("uav-3", 20.0)]
    now = [0.0]
    coordinator = SwarmCoordinator(
        SwarmKey.generate("mina"), [u.member(30.0 + 10 * i) for i, u in enumerate(uavs)], split(AREA, 3, home=HOME),
        audit=MemoryAudit(), log=lambda _: None, clock=lambda: now[0],
        heartbeat=Heartbeat(period_s=1.0, timeout_s=TIMEOUT_S),
    )  # fmt: skip
    coordinator.now = now  # type: ignore[attr-defined]
    yield coordinator
    coordinator.close()


def _tick(swarm: SwarmCoordinator, beating: list[str], seconds: float = 1.0) -> None:
    """``seconds`` of the swarm's clock with ``beating`` sending their heartbeats, the members watched."""
    swarm.now[0] += seconds  # type: ignore[attr-defined]
    for uav in beating:
        swarm.heartbeats.beat(uav)
    swarm.watch()


def _lost_ground(swarm: SwarmCoordinator) -> dict[str, str]:
    awarded = swarm.allocate_sectors()
    swarm.now[0] = 30.0  # type: ignore[attr-defined]
    swarm.lose_ground("test")
    return awarded


def test_a_silent_uav_fails_after_the_timeout_though_memory_says_it_lives(swarm: SwarmCoordinator) -> None:
    awarded = _lost_ground(swarm)
    victim = awarded["S2"]
    others = [u for u in swarm.members if u != victim]
    for _ in range(int(TIMEOUT_S)):  # all beating: nobody fails, however long
        _tick(swarm, list(swarm.members))
    _tick(swarm, list(swarm.members), seconds=3.0)
    assert swarm.failed == []
    silent_from = swarm.now[0]  # type: ignore[attr-defined]
    while victim not in swarm.failed:
        _tick(swarm, others)
        assert swarm.now[0] - silent_from <= TIMEOUT_S + 1.0  # type: ignore[attr-defined]
    assert swarm.now[0] - silent_from > TIMEOUT_S  # type: ignore[attr-defined]
    assert swarm.members[victim].alive()  # shared memory still says so: the messages decided
    assert swarm.failed == [victim] and swarm.manager.allocation.awarded["survey:S2"] in others


def test_heartbeats_start_only_without_the_ground_and_are_signed_per_peer(swarm: SwarmCoordinator) -> None:
    sent: list[tuple[str, str]] = []

    def keep(to: str, raw: str) -> bool:
        sent.append((to, raw))
        return True

    swarm.heartbeats.deliver = keep
    swarm.heartbeats.beat("uav-1")
    assert sent == []  # the ground still judges who lives
    _lost_ground(swarm)
    swarm.heartbeats.beat("uav-1")
    swarm.heartbeats.beat("uav-1")  # not due yet on the swarm's clock
    assert sorted(to for to, _ in sent) == ["uav-2", "uav-3"]
    assert all(swarm.heartbeats.hear(to, raw) for to, raw in sent)


@pytest.mark.parametrize("attack", ["forged", "replayed"])
def test_a_forged_or_replayed_heartbeat_keeps_a_dead_uav_dead(swarm: SwarmCoordinator, attack: str) -> None:
    awarded = _lost_ground(swarm)
    victim = awarded["S1"]
    others = [u for u in swarm.members if u != victim]
    captured: list[tuple[str, str]] = []
    deliver = swarm.heartbeats.deliver

    def tap(to: str, raw: str) -> bool:
        captured.append((to, raw))
        return deliver(to, raw)

    swarm.heartbeats.deliver = tap
    _tick(swarm, list(swarm.members))  # the victim's last genuine heartbeats, on the wire
    old = [(to, raw) for to, raw in captured if f'"sender":"{victim}"' in raw]
    assert len(old) == 2
    refused: list[Any] = []
    while victim not in swarm.failed and swarm.now[0] < 60.0:  # type: ignore[attr-defined]
        for to in others:  # the attacker speaks for the dead UAV every second
            if attack == "forged":
                fake = Sealer(SwarmKey.generate("mina"), victim).seal("heartbeat", {"t": 0}, recipient=to)
                refused.append(swarm.heartbeats.hear(to, fake.model_dump_json()))
            else:
                refused += [swarm.heartbeats.hear(peer, raw) for peer, raw in old if peer == to]
        _tick(swarm, others)
    assert victim in swarm.failed and not any(refused)
    reasons = {r.reason for r in swarm.audit.rejections if r.sender == victim}  # type: ignore[attr-defined]
    assert reasons == {attack}
    assert swarm.manager.allocation.awarded["survey:S1"] in others


def test_a_heartbeat_timeout_under_two_periods_is_refused() -> None:
    with pytest.raises(ValueError, match="under two periods"):
        Heartbeat(period_s=5.0, timeout_s=6.0)
