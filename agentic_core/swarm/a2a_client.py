"""Our A2A client of one peer: discovers its Agent Card (and so its state), sends it a signed swarm message and
checks the signed reply with the caller's :class:`~agentic_core.swarm.signing.Guard`. JSON-RPC framing, card
resolution and transports are the a2a-sdk's; what is ours is the swarm message inside.

>>> import asyncio
>>> from agentic_core.contracts.swarm import Point, UavState
>>> from agentic_core.swarm.a2a_server import A2AServer
>>> from agentic_core.swarm.signing import Guard, SwarmKey
>>> class Idle:
...     def state(self) -> UavState:
...         return UavState(uav_id="uav-2", position=Point(north=3, east=4), battery_pct=55)
...     async def handle(self, message):
...         return None
>>> async def ask(url: str) -> float:
...     async with A2APeer(url) as peer:
...         return (await peer.state()).battery_pct
>>> with A2AServer(Idle(), Guard(SwarmKey.generate("mina"), "uav-2")) as server:
...     asyncio.run(ask(server.url))
55.0
"""

from __future__ import annotations

from typing import Any

from agentic_core.swarm.a2a_extra import missing

try:
    import httpx
    from a2a.client import A2ACardResolver, ClientConfig, ClientFactory
    from a2a.client.client import Client
    from a2a.client.errors import A2AClientError
    from a2a.helpers.proto_helpers import get_data_parts, get_message_text, new_message, new_text_part
    from a2a.types.a2a_pb2 import AgentCard, Message, Role, SendMessageRequest
except ImportError as exc:
    raise missing(exc) from exc

from agentic_core.contracts.errors import RunFailure
from agentic_core.contracts.swarm import SwarmMessage, UavState
from agentic_core.swarm.a2a_server import swarm_part, swarm_text
from agentic_core.swarm.card import SIGNED_EXTENSION, state_from_card
from agentic_core.swarm.card_signing import verify_card
from agentic_core.swarm.signing import Guard, SwarmKey

TIMEOUT_S = 5.0


class PeerError(RunFailure):
    """A peer that could not be reached, answered nothing usable, or refused what we sent (``refused``: why)."""

    def __init__(self, message: str, *, refused: str | None = None) -> None:
        super().__init__(message)
        self.refused = refused


class A2APeer:
    """One A2A agent at ``base_url``, reached over HTTP; use as ``async with``."""

    def __init__(
        self,
        base_url: str,
        *,
        guard: Guard | None = None,
        timeout_s: float = TIMEOUT_S,
        card_key: SwarmKey | None = None,
    ) -> None:
        self.base_url = base_url.rstrip("/")
        self.guard = guard
        self.card_key = card_key
        """With a key, a card is believed only when its JWS verifies (:mod:`.card_signing`): else ``CardRejected``."""
        self._http = httpx.AsyncClient(timeout=timeout_s)
        self._client: Client | None = None

    async def card(self) -> AgentCard:
        """The peer's Agent Card, fetched now from ``/.well-known/agent-card.json``."""
        try:
            card = await A2ACardResolver(self._http, self.base_url).get_agent_card()
        except (A2AClientError, httpx.HTTPError) as exc:
            raise PeerError(f"{self.base_url}: no agent card ({exc})") from exc
        if self.card_key is not None:
            verify_card(card, self.card_key)
        return card

    async def state(self) -> UavState:
        """The state the peer's card advertises now."""
        return state_from_card(await self.card())

    async def ask(self, text: str) -> Message:
        """Send plain text; the peer's reply message."""
        return await self._send(new_message([new_text_part(text)], role=Role.ROLE_USER))

    async def send(self, message: SwarmMessage) -> SwarmMessage | None:
        """Send a signed swarm message; the peer's signed reply (checked by our guard), or None for none.

        :class:`PeerError` when the peer refused it (``refused`` is its reason) or the link failed."""
        request = new_message([swarm_part(message)], role=Role.ROLE_USER)
        request.extensions.append(SIGNED_EXTENSION)
        reply = await self._send(request)
        text = swarm_text(reply)
        if text is not None:
            return self.guard.parse(text) if self.guard is not None else SwarmMessage.model_validate_json(text)
        for data in get_data_parts(reply.parts):
            if isinstance(data, dict) and "refused" in data:
                raise PeerError(f"{self.base_url} refused {message.kind}: {data['refused']}", refused=data["refused"])
        return None

    async def _send(self, message: Message) -> Message:
        client = await self._connect()
        try:
            async for event in client.send_message(SendMessageRequest(message=message)):
                if event.HasField("message"):
                    return event.message
                if event.HasField("task") and event.task.status.HasField("message"):
                    return event.task.status.message
        except (A2AClientError, httpx.HTTPError) as exc:
            raise PeerError(f"{self.base_url}: {type(exc).__name__}: {exc}") from exc
        raise PeerError(f"{self.base_url} answered no message")

    async def _connect(self) -> Client:
        if self._client is None:
            config = ClientConfig(streaming=False, httpx_client=self._http)
            self._client = ClientFactory(config).create(await self.card())
        return self._client

    async def aclose(self) -> None:
        """Close the HTTP connections."""
        await self._http.aclose()

    async def __aenter__(self) -> A2APeer:
        return self

    async def __aexit__(self, *_: Any) -> None:
        await self.aclose()


def reply_text(message: Message) -> str:
    """The text of an A2A reply (what a person reads)."""
    return get_message_text(message)


__all__ = ["A2APeer", "PeerError", "reply_text"]
