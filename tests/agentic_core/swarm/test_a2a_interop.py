"""Interoperability with the official a2a-sdk, both ways, over HTTP on 127.0.0.1: the SDK's client discovers our
UAV's Agent Card and calls it; our client calls an agent the SDK serves."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Iterator

import httpx
import pytest
from a2a.client import ClientConfig, create_client
from a2a.helpers.proto_helpers import get_data_parts, get_message_text, new_message, new_text_part
from a2a.server.agent_execution import AgentExecutor, RequestContext
from a2a.server.events import EventQueue
from a2a.types.a2a_pb2 import Message, Role, SendMessageRequest

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.swarm import Point, SwarmMessage
from agentic_core.swarm.a2a_client import A2APeer, PeerError
from agentic_core.swarm.a2a_server import A2AServer, swarm_part, swarm_text
from agentic_core.swarm.card import CONTRACT_NET_EXTENSION, SIGNED_EXTENSION, STATE_EXTENSION, SWARM_MEDIA_TYPE
from agentic_core.swarm.signing import Guard, MemoryAudit, Sealer, SwarmKey
from tests.agentic_core.swarm.conftest import EchoUav, uav

from .sdk_agent import SdkAgent


@pytest.fixture
def agent(key: SwarmKey) -> EchoUav:
    return uav("uav-1", key, payload=("medkit",), battery_pct=64.0)


@pytest.fixture
def served(agent: EchoUav, key: SwarmKey) -> Iterator[A2AServer]:
    with A2AServer(agent, Guard(key, "uav-1", audit=MemoryAudit())) as server:
        yield server


async def _sdk_send(url: str, message: Message) -> Message:
    async with httpx.AsyncClient(timeout=5.0) as http:
        client = await create_client(url, ClientConfig(streaming=False, httpx_client=http))
        replies = [event async for event in client.send_message(SendMessageRequest(message=message))]
    assert len(replies) == 1 and replies[0].HasField("message")
    return replies[0].message


def test_the_card_is_at_the_well_known_path_with_skills_and_state(served: A2AServer, agent: EchoUav) -> None:
    card = httpx.get(served.url + "/.well-known/agent-card.json", timeout=5.0).json()
    assert {s["id"] for s in card["skills"]} == {"survey_sector", "verify_casualty", "deliver_kit"}
    assert card["supportedInterfaces"][0]["url"] == served.url + "/a2a"
    extensions = {e["uri"]: e for e in card["capabilities"]["extensions"]}
    assert set(extensions) == {STATE_EXTENSION, SIGNED_EXTENSION, CONTRACT_NET_EXTENSION}
    assert extensions[STATE_EXTENSION]["params"]["battery_pct"] == agent.current.battery_pct
    assert extensions[STATE_EXTENSION]["params"]["payload"] == ["medkit"]


def test_the_card_says_the_state_now_not_the_state_at_start(served: A2AServer, agent: EchoUav) -> None:
    agent.current = agent.current.model_copy(update={"battery_pct": 31.5, "position": Point(north=7, east=8, alt=40)})

    async def read() -> tuple[float, Point]:
        async with A2APeer(served.url) as peer:
            state = await peer.state()
        return state.battery_pct, state.position

    assert asyncio.run(read()) == (31.5, Point(north=7, east=8, alt=40))


def test_the_sdk_client_discovers_and_calls_our_uav(served: A2AServer, agent: EchoUav) -> None:
    reply = asyncio.run(_sdk_send(served.url, new_message([new_text_part("status?")], role=Role.ROLE_USER)))
    assert "uav-1" in get_message_text(reply) and "64%" in get_message_text(reply)
    assert get_data_parts(reply.parts)[0]["battery_pct"] == agent.current.battery_pct


def test_the_sdk_client_carries_a_signed_swarm_message_and_gets_a_signed_reply(
    served: A2AServer, agent: EchoUav, key: SwarmKey
) -> None:
    sent = Sealer(key, "ground").seal("cfp", {"task": "T-1"}, recipient="uav-1")
    reply = asyncio.run(_sdk_send(served.url, new_message([swarm_part(sent)], role=Role.ROLE_USER)))
    text = swarm_text(reply)
    assert text is not None and SIGNED_EXTENSION in reply.extensions
    answer = Guard(key, "ground").parse(text)
    assert (answer.kind, answer.sender, answer.body) == ("inform", "uav-1", {"echo": {"task": "T-1"}})
    assert [m.nonce for m in agent.heard] == [sent.nonce]


def test_our_client_gets_a_refusal_not_a_reply_for_a_message_signed_with_another_key(
    served: A2AServer, agent: EchoUav
) -> None:
    forged = Sealer(SwarmKey.generate("mina"), "ground").seal("award", {"task": "T-1"}, recipient="uav-1")

    async def send() -> None:
        async with A2APeer(served.url) as peer:
            await peer.send(forged)

    with pytest.raises(PeerError) as refused:
        asyncio.run(send())
    assert refused.value.refused == "forged" and agent.heard == []
    assert [r.reason for r in served.guard.audit.rejections] == ["forged"]  # type: ignore[attr-defined]


@pytest.fixture
def sdk_agent() -> Iterator[SdkAgent]:
    with SdkAgent(Echo()) as agent:
        yield agent


class Echo(AgentExecutor):
    """An agent written as the SDK's users write them: it echoes the text (and any swarm message) it gets."""

    async def execute(self, context: RequestContext, event_queue: EventQueue) -> None:
        assert context.message is not None
        await event_queue.enqueue_event(new_message(list(context.message.parts), context_id=context.context_id))

    async def cancel(self, context: RequestContext, event_queue: EventQueue) -> None:
        raise NotImplementedError


def test_our_client_calls_an_agent_the_sdk_serves(sdk_agent: SdkAgent, key: SwarmKey) -> None:
    sent = Sealer(key, "uav-1").seal("state", {"battery_pct": 50}, recipient="uav-1")

    async def talk() -> tuple[str, str, SwarmMessage | None]:
        async with A2APeer(sdk_agent.url, guard=Guard(key, "uav-1")) as peer:
            card = await peer.card()
            reply = await peer.ask("hello, swarm")
            echoed = await peer.send(sent)
        return card.name, get_message_text(reply), echoed

    name, text, echoed = asyncio.run(talk())
    assert (name, text) == ("sdk-echo", "hello, swarm")
    assert echoed == sent  # the SDK carried our signed message through untouched, and our guard accepted it


def test_a_peer_without_uav_state_is_a_clear_error(sdk_agent: SdkAgent) -> None:
    async def read() -> None:
        async with A2APeer(sdk_agent.url) as peer:
            await peer.state()

    with pytest.raises(InputError, match=r"sdk-echo.*has no urn:agentic-uavs:a2a:uav-state:v1"):
        asyncio.run(read())


def test_a_peer_that_is_not_there_is_a_peer_error_not_a_traceback() -> None:
    with A2AServer(uav("gone", SwarmKey.generate("m")), Guard(SwarmKey.generate("m"), "gone")) as server:
        url = server.url

    async def read() -> None:
        async with A2APeer(url, timeout_s=1.0) as peer:
            await peer.card()

    with pytest.raises(PeerError, match="no agent card"):
        asyncio.run(read())


def test_the_card_json_is_plain_json_any_client_can_read(served: A2AServer) -> None:
    raw = httpx.get(served.url + "/.well-known/agent-card.json", timeout=5.0).text
    assert json.loads(raw)["name"] == "uav-1"


def test_a_replayed_or_garbled_message_over_a2a_is_refused_and_audited(
    served: A2AServer, agent: EchoUav, key: SwarmKey
) -> None:
    award = Sealer(key, "ground").seal("award", {"task": "T-1"}, recipient="uav-1")
    garbled = new_message([new_text_part('{"kind": "award", "sender": "ground"', media_type=SWARM_MEDIA_TYPE)])

    async def send() -> tuple[SwarmMessage | None, str | None, Message]:
        async with A2APeer(served.url) as peer:
            first = await peer.send(award)
            try:
                await peer.send(award)
            except PeerError as exc:
                refused = exc.refused
            else:
                refused = None
        return first, refused, await _sdk_send(served.url, garbled)

    first, refused, garbled_reply = asyncio.run(send())
    assert first is not None and first.kind == "inform" and refused == "replayed"
    assert get_data_parts(garbled_reply.parts) == [{"refused": "malformed"}]
    assert [m.nonce for m in agent.heard] == [award.nonce]
    assert [r.reason for r in served.guard.audit.rejections] == ["replayed", "malformed"]  # type: ignore[attr-defined]
