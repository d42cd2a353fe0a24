"""A UAV's A2A server: the a2a-sdk's JSON-RPC and Agent Card routes on Starlette, served by uvicorn on 127.0.0.1
in a thread of its own (``a2a-<uav>``), behind :class:`SwarmExecutor`, which opens the signed swarm message a
request carries, refuses it (audited) when forged, stale or replayed, and answers with the agent's signed reply.

A request without a swarm message (any A2A client's plain text) is answered with the UAV's state.

>>> import asyncio
>>> from agentic_core.contracts.swarm import Point, UavState
>>> from agentic_core.swarm.signing import Guard, SwarmKey
>>> class Idle:
...     def state(self) -> UavState:
...         return UavState(uav_id="uav-1", position=Point(north=0, east=0), battery_pct=90)
...     async def handle(self, message):
...         return None
>>> key = SwarmKey.generate("mina")
>>> with A2AServer(Idle(), Guard(key, "uav-1")) as server:
...     server.url.startswith("http://127.0.0.1:")
True
"""

from __future__ import annotations

import asyncio
import socket
import threading
from typing import Protocol

from agentic_core.swarm.a2a_extra import missing

try:
    import uvicorn
    from a2a.helpers.proto_helpers import new_data_part, new_message, new_text_part
    from a2a.server.agent_execution import AgentExecutor, RequestContext
    from a2a.server.events import EventQueue
    from a2a.server.request_handlers import DefaultRequestHandler
    from a2a.server.routes import create_agent_card_routes, create_jsonrpc_routes
    from a2a.server.tasks import InMemoryTaskStore
    from a2a.types.a2a_pb2 import AgentCard, Message, Part, Role
    from starlette.applications import Starlette
except ImportError as exc:
    raise missing(exc) from exc

from agentic_core.contracts.errors import RunFailure
from agentic_core.contracts.swarm import SwarmMessage, UavState
from agentic_core.swarm.card import RPC_PATH, SIGNED_EXTENSION, SWARM_MEDIA_TYPE, uav_card, with_state
from agentic_core.swarm.card_signing import sign_card
from agentic_core.swarm.signing import Guard, Refused, SwarmKey

START_TIMEOUT_S = 10.0


class SwarmAgent(Protocol):
    """What an A2A server serves: the aircraft's state, and the answer to a verified swarm message."""

    def state(self) -> UavState:
        """The aircraft's state now (the card's extension)."""

    async def handle(self, message: SwarmMessage) -> SwarmMessage | None:
        """The signed reply to ``message`` (already verified), or None for no reply."""


def swarm_part(message: SwarmMessage) -> Part:
    """The A2A part that carries a signed swarm message: its JSON as text, with the swarm media type."""
    return new_text_part(message.model_dump_json(), media_type=SWARM_MEDIA_TYPE)


def swarm_text(message: Message) -> str | None:
    """The JSON text of the swarm message an A2A message carries, or None."""
    return next((p.text for p in message.parts if p.HasField("text") and p.media_type == SWARM_MEDIA_TYPE), None)


class SwarmExecutor(AgentExecutor):
    """The a2a-sdk executor of a UAV: every reply is one A2A ``Message`` (no long-running task)."""

    def __init__(self, agent: SwarmAgent, guard: Guard) -> None:
        self.agent = agent
        self.guard = guard

    async def execute(self, context: RequestContext, event_queue: EventQueue) -> None:
        """Answer one request: a swarm message with the agent's reply, anything else with the state."""
        incoming = context.message
        text = swarm_text(incoming) if incoming is not None else None
        if text is None:
            state = self.agent.state()
            parts = [new_text_part(_describe(state)), new_data_part(state.model_dump(mode="json"))]
        else:
            try:
                reply = await self.agent.handle(self.guard.parse(text))
            except Refused as exc:
                parts = [new_text_part(str(exc)), new_data_part({"refused": exc.rejection.reason})]
            else:
                parts = [swarm_part(reply)] if reply else [new_text_part("received")]
        answer = new_message(parts, context_id=context.context_id, task_id=context.task_id, role=Role.ROLE_AGENT)
        if text is not None:
            answer.extensions.append(SIGNED_EXTENSION)
        await event_queue.enqueue_event(answer)

    async def cancel(self, context: RequestContext, event_queue: EventQueue) -> None:
        """Nothing runs long enough to cancel: every request is answered at once."""


def _describe(state: UavState) -> str:
    p = state.position
    kit = ", ".join(state.payload) or "nothing"
    return (
        f"{state.uav_id}: {state.status}, battery {state.battery_pct:.0f}%, carrying {kit}, "
        f"at {p.north:.0f} m N {p.east:.0f} m E {p.alt:.0f} m up"
    )


class A2AServer:
    """Serves one UAV over A2A on 127.0.0.1 (a free port unless ``port`` is given) until :meth:`close`."""

    def __init__(
        self,
        agent: SwarmAgent,
        guard: Guard,
        *,
        host: str = "127.0.0.1",
        port: int = 0,
        card_key: SwarmKey | None = None,
    ) -> None:
        self.agent = agent
        self.guard = guard
        self.card_key = card_key
        """With a key, every card served is signed (a JWS in ``signatures``: :mod:`.card_signing`)."""
        self._socket = socket.create_server((host, port))
        self.host, self.port = self._socket.getsockname()[:2]
        self.url = f"http://{self.host}:{self.port}"
        self.card: AgentCard = uav_card(agent.state(), self.url)
        handler = DefaultRequestHandler(SwarmExecutor(agent, guard), InMemoryTaskStore(), self.card)
        routes = [
            *create_agent_card_routes(self.card, card_modifier=self._fresh_card),
            *create_jsonrpc_routes(handler, RPC_PATH),
        ]
        config = uvicorn.Config(Starlette(routes=routes), log_level="warning", lifespan="off", access_log=False)
        self._server = uvicorn.Server(config)
        name = f"a2a-{agent.state().uav_id}"
        self._thread = threading.Thread(target=self._serve, name=name, daemon=True)
        self._thread.start()
        if not self._wait_started():
            self.close()
            raise RunFailure(f"the A2A server of {name} did not start within {START_TIMEOUT_S:g} s")

    async def _fresh_card(self, card: AgentCard) -> AgentCard:
        fresh = with_state(card, self.agent.state())
        return sign_card(fresh, self.card_key) if self.card_key is not None else fresh

    def _serve(self) -> None:
        asyncio.run(self._server.serve(sockets=[self._socket]))

    def _wait_started(self) -> bool:
        done = threading.Event()
        for _ in range(int(START_TIMEOUT_S / 0.01)):
            if self._server.started or not self._thread.is_alive():
                break
            done.wait(0.01)
        return self._server.started

    def close(self) -> None:
        """Stop serving and join the thread (idempotent)."""
        self._server.should_exit = True
        self._thread.join(timeout=START_TIMEOUT_S)
        self._socket.close()

    def __enter__(self) -> A2AServer:
        return self

    def __exit__(self, *_: object) -> None:
        self.close()


__all__ = ["A2AServer", "SwarmAgent", "SwarmExecutor", "swarm_part", "swarm_text"]
