"""Synchronous calls: ``chat_sync`` sent from the calling thread (no event loop, no other thread), from plain
code and from inside a running event loop; on the client's own event loop thread only when a transport serves
async calls alone; and closing it."""

from __future__ import annotations

import asyncio
import json
import threading
from collections.abc import Callable

import httpx

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


def test_chat_sync_sends_from_the_calling_thread(standin: StandIn, openai_client: MakeClient) -> None:
    def ours() -> set[threading.Thread]:  # all threads but the stand-in server's, one per connection
        return {t for t in threading.enumerate() if "process_request_thread" not in t.name}

    standin.script(openai_completion("here"), openai_completion('{"n": 1}'))
    before = ours()
    with openai_client() as client:
        assert client.warm() is None
        assert client.chat_sync(REQUEST).content == "here"
        assert client.chat_structured_sync(REQUEST, {"type": "object"}, name="n").parsed == {"n": 1}
        assert ours() == before  # no event loop thread, no worker: this thread sent them


class AsyncOnly(httpx.AsyncBaseTransport):
    """A transport that serves async calls only (as ``httpx.AsyncHTTPTransport`` does)."""

    async def handle_async_request(self, request: httpx.Request) -> httpx.Response:
        body = openai_completion("from the loop thread").body
        return httpx.Response(200, content=json.dumps(body), headers={"Content-Type": "application/json"})


def test_an_async_only_transport_is_served_from_the_clients_event_loop() -> None:
    client = OpenAICompatibleClient("m", "http://model.test/v1", transport=AsyncOnly(), trust_env=False)
    try:
        assert client.chat_sync(REQUEST).content == "from the loop thread"
        assert any(t.name == "llm-client-loop" for t in threading.enumerate())
    finally:
        client.close()
    assert not any(t.name == "llm-client-loop" and t.is_alive() for t in threading.enumerate())


def test_a_transport_that_breaks_oddly_is_a_result_both_ways() -> None:
    def handler(request: httpx.Request) -> httpx.Response:
        raise StopIteration  # e.g. a scripted transport that ran out of replies

    transport = httpx.MockTransport(handler)
    client = OpenAICompatibleClient("m", "http://model.test/v1", transport=transport, trust_env=False)
    try:
        results = [client.chat_sync(REQUEST), asyncio.run(client.chat(REQUEST))]
    finally:
        client.close()
    assert [r.status for r in results] == ["http_error", "http_error"]
    assert all(r.error is not None and r.error.startswith("internal error") for r in results)
    assert client.totals.calls == 2 and client.totals.failures == 2


class SyncOnly(httpx.BaseTransport):
    """A transport that serves synchronous calls only (as ``httpx.HTTPTransport`` does)."""

    def handle_request(self, request: httpx.Request) -> httpx.Response:
        body = openai_completion("from this thread").body
        return httpx.Response(200, content=json.dumps(body), headers={"Content-Type": "application/json"})


def test_a_sync_only_transport_serves_chat_sync_and_refuses_chat() -> None:
    client = OpenAICompatibleClient("m", "http://127.0.0.1:9/v1", transport=SyncOnly(), trust_env=False)
    try:
        assert client.chat_sync(REQUEST).content == "from this thread"
        refused = asyncio.run(client.chat(REQUEST))  # never sent to the network instead
    finally:
        client.close()
    assert refused.status == "http_error" and "synchronous calls only" in (refused.error or "")
