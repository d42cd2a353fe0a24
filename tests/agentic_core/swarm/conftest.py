"""What the swarm's tests share: a swarm key, a UAV agent whose state a test can change, and a test clock."""

from __future__ import annotations

from dataclasses import dataclass, field

import pytest

from agentic_core.contracts.swarm import Point, SwarmMessage, UavState
from agentic_core.swarm.signing import Sealer, SwarmKey


@pytest.fixture
def key() -> SwarmKey:
    return SwarmKey.generate("mina")


@dataclass
class Clock:
    """A clock a test moves by hand."""

    now: float = 1_000.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@dataclass
class EchoUav:
    """A UAV agent that answers every swarm message with a signed ``inform`` echoing its body."""

    sealer: Sealer
    current: UavState
    heard: list[SwarmMessage] = field(default_factory=list)

    def state(self) -> UavState:
        return self.current

    async def handle(self, message: SwarmMessage) -> SwarmMessage | None:
        self.heard.append(message)
        return self.sealer.seal("inform", {"echo": message.body}, recipient=message.sender)


def uav(uav_id: str, key: SwarmKey, **state: object) -> EchoUav:
    defaults: dict[str, object] = {"position": Point(north=0, east=0, alt=30), "battery_pct": 80.0}
    return EchoUav(Sealer(key, uav_id), UavState.model_validate({"uav_id": uav_id, **defaults, **state}))
