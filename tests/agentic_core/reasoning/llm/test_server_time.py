"""The model's own time: what the server says it spent (OpenAI's ``openai-processing-ms`` header, Ollama's
``total_duration``), kept apart from the whole call's latency and summed over a call's requests; nothing when the
server does not say."""

from __future__ import annotations

import json
from collections.abc import Callable

import httpx
import pytest

from agentic_core.reasoning.llm import ChatRequest, Message, OllamaClient, OpenAICompatibleClient
from agentic_core.reasoning.llm.transport import processing_s

from .conftest import Ask, Send
from .standin import Reply, StandIn, ollama_chat, openai_completion

MakeClient = Callable[..., OpenAICompatibleClient]
REQUEST = ChatRequest(messages=[Message.user("Anyone in need?")])


def said(ms: str) -> Reply:
    reply = openai_completion('{"n": 1}')
    reply.headers["openai-processing-ms"] = ms
    return reply


def test_the_header_openai_sends_is_the_servers_time(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(said("812"))
    result = send(openai_client(), REQUEST)
    assert result.ok and result.server_s == pytest.approx(0.812)


def test_the_stand_in_says_how_long_it_worked(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    reply = openai_completion("slow")
    reply.stall_s = 0.2
    standin.script(reply)
    result = send(openai_client(), REQUEST)
    assert result.server_s is not None and 0.2 <= result.server_s <= result.latency_s


def test_ollamas_total_duration(standin: StandIn, ollama_client: Callable[..., OllamaClient], send: Send) -> None:
    standin.script(ollama_chat("ok"))  # total_duration 885095291 ns, as Ollama's documentation shows
    assert send(ollama_client(), REQUEST).server_s == pytest.approx(0.885095291)


def test_a_correction_round_adds_both_requests(standin: StandIn, openai_client: MakeClient, ask: Ask) -> None:
    fixed = openai_completion('{"persons": 1}')
    fixed.headers["openai-processing-ms"] = "50"
    standin.script(said("100"), fixed)  # the first reply lacks "persons": it is shown back once
    result = ask(openai_client(), REQUEST, {"type": "object", "required": ["persons"]}, name="count")
    assert result.ok and result.repaired and result.attempts == 2 and result.server_s == pytest.approx(0.15)


def test_a_server_that_does_not_say(send: Send) -> None:
    def answer(request: httpx.Request) -> httpx.Response:
        body = openai_completion("quiet").body
        return httpx.Response(200, content=json.dumps(body), headers={"Content-Type": "application/json"})

    client = OpenAICompatibleClient("m", "http://model.test/v1", transport=httpx.MockTransport(answer), trust_env=False)
    result = send(client, REQUEST)
    assert result.ok and result.server_s is None


@pytest.mark.parametrize("value", ["", "soon", "-3", "nan", "inf"])
def test_a_header_that_is_not_a_time_is_not_one(value: str) -> None:
    assert processing_s(httpx.Headers({"openai-processing-ms": value})) is None
