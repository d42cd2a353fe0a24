"""Listening on the swarm's wire in tests: every message the ground sends a UAV, in order, beside the real send."""

from __future__ import annotations

from typing import Any

from agentic_core.contracts.swarm import SwarmMessage
from agentic_core.swarm.coordinator import SwarmCoordinator


def tap_wire(swarm: SwarmCoordinator) -> list[tuple[str, SwarmMessage]]:
    """A list that fills with (UAV, message) for every message the ground sends from now on."""
    wire: list[tuple[str, SwarmMessage]] = []
    for uav, channel in swarm.channels.items():
        send = channel.send

        async def tap(message: SwarmMessage, uav: str = uav, send: Any = send) -> SwarmMessage | None:
            wire.append((uav, message))
            reply: SwarmMessage | None = await send(message)
            return reply

        channel.send = tap  # type: ignore[method-assign]
    return wire
