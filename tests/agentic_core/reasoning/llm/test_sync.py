"""The synchronous wrapper: ``chat_sync`` on the client's own event loop thread, from plain code and from inside
a running event loop, and closing it."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from agentic_core.reasoning.llm import ChatRequest, LLMClient, Message, OpenAICompatibleClient

from .standin import StandIn, openai_completion

MakeClient = Callable[..., OpenAICompatibleClient]
REQUEST = ChatRequest(messages=[Message.user("hi")])


def test_chat_sync(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("one"), openai_completion('{"n": 2}'))
    with openai_client() as client:
        assert client.chat_sync(REQUEST).content == "one"
        result = client.chat_structured_sync(REQUEST, {"type": "object"}, name="n")
        assert result.parsed == {"n": 2}
    assert client.totals.calls == 2


def test_chat_sync_inside_a_running_loop(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("from a sync node"))
    client = openai_client()

    async def node() -> str | None:
        return client.chat_sync(REQUEST).content  # a synchronous graph node called from async code

    try:
        assert asyncio.run(node()) == "from a sync node"
    finally:
        client.close()
    client.close()  # twice is harmless


def test_clients_satisfy_the_protocol(openai_client: MakeClient) -> None:
    assert isinstance(openai_client(), LLMClient)
