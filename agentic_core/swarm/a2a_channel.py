"""A member of the swarm reached over A2A: the UAV's own A2A server on 127.0.0.1 (its signed Agent Card, with its
live state, and the JSON-RPC endpoint whose :class:`~agentic_core.swarm.signing.Guard` checks every message) and the
manager's A2A client of it, which believes the card only when its signature verifies and checks every reply with the
manager's guard. A drop-in :class:`~agentic_core.swarm.contract_net.Channel` for the Contract Net manager.

>>> import asyncio
>>> from agentic_core.contracts.swarm import Point, SwarmTask, UavState
>>> from agentic_core.swarm.contract_net import Manager, Participant
>>> from agentic_core.swarm.signing import Guard, Sealer, SwarmKey
>>> key = SwarmKey.generate("mina")
>>> state = UavState(uav_id="uav-1", position=Point(north=0, east=0, alt=30), battery_pct=90)
>>> agent = Participant(Sealer(key, "uav-1"), lambda: state, manager="ground")
>>> channel = A2AChannel(agent, Guard(key, "uav-1"), reply_guard=Guard(key, "ground"), card_key=key)
>>> manager = Manager(Sealer(key, "ground"), Guard(key, "ground"), {"uav-1": channel})
>>> task = SwarmTask(id="T-1", skill="survey_sector", where=Point(north=50, east=0, alt=30))
>>> async def auction() -> dict[str, str]:
...     awarded = (await manager.allocate([task])).awarded
...     await channel.aclose()
...     return awarded
>>> asyncio.run(auction()), channel.requests
({'T-1': 'uav-1'}, 2)
>>> channel.close()
"""

from __future__ import annotations

from agentic_core.contracts.swarm import SwarmMessage
from agentic_core.swarm.a2a_client import A2APeer, PeerError
from agentic_core.swarm.a2a_server import A2AServer
from agentic_core.swarm.contract_net import Participant
from agentic_core.swarm.signing import Guard, SwarmKey


class A2AChannel:
    """One UAV served over A2A (a thread ``a2a-<uav>``) and reached through our client; :meth:`close` stops it."""

    def __init__(self, agent: Participant, guard: Guard, *, reply_guard: Guard, card_key: SwarmKey) -> None:
        self.agent = agent
        self.uav = agent.sealer.sender
        self.server = A2AServer(agent, guard, card_key=card_key)
        self.url = self.server.url
        """The UAV's A2A base URL: its card at ``/.well-known/agent-card.json``, JSON-RPC at ``/a2a``."""
        self.peer = A2APeer(self.url, guard=reply_guard, card_key=card_key)
        self.alive = True
        self.requests = 0
        """Swarm messages sent over HTTP (answered or not)."""

    async def send(self, message: SwarmMessage) -> SwarmMessage | None:
        """Post ``message`` to the UAV's A2A endpoint; its reply, checked. A lost UAV is not called
        (:class:`~agentic_core.swarm.a2a_client.PeerError`, as when it does not answer)."""
        if not self.alive:
            raise PeerError(f"{self.uav}: its link is lost")
        self.requests += 1
        return await self.peer.send(message)

    async def aclose(self) -> None:
        """Close the client's connections (on the loop that used them)."""
        await self.peer.aclose()

    def close(self) -> None:
        """Stop the UAV's A2A server (idempotent)."""
        self.server.close()


__all__ = ["A2AChannel"]
