"""Fixtures for the LLM client tests: a running stand-in server, a recording sleep, and clients pointed at the
stand-in (never at the network beyond 127.0.0.1: proxies from the environment are ignored)."""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Iterator
from typing import Any

import pytest

from agentic_core.reasoning.llm import (
    ChatRequest,
    HTTPChatClient,
    LLMResult,
    OllamaClient,
    OpenAICompatibleClient,
    RetryPolicy,
    chat_structured,
)

from .standin import StandIn

KEY = "sk-proj-Zq9XwV7tU5sR3pN1mL0kJ8hG6fD4sA2q"
FAST_RETRY = RetryPolicy(attempts=3, initial_s=0.5, max_s=4, jitter_s=0, max_retry_after_s=30)


class RecordingSleep:
    """The clients' ``sleep``: records each wait between retries and returns at once."""

    def __init__(self) -> None:
        self.delays: list[float] = []

    async def __call__(self, seconds: float) -> None:
        self.delays.append(seconds)


@pytest.fixture
def standin() -> Iterator[StandIn]:
    with StandIn() as server:
        yield server


@pytest.fixture
def sleep() -> RecordingSleep:
    return RecordingSleep()


@pytest.fixture
def openai_client(standin: StandIn, sleep: RecordingSleep) -> Callable[..., OpenAICompatibleClient]:
    def make(**options: Any) -> OpenAICompatibleClient:
        settings: dict[str, Any] = {"api_key": KEY, "sleep": sleep, "retry": FAST_RETRY, "trust_env": False}
        settings.update(options)
        return OpenAICompatibleClient("gpt-4o", standin.url + "/v1", **settings)

    return make


@pytest.fixture
def ollama_client(standin: StandIn, sleep: RecordingSleep) -> Callable[..., OllamaClient]:
    def make(**options: Any) -> OllamaClient:
        settings: dict[str, Any] = {"sleep": sleep, "retry": FAST_RETRY, "trust_env": False}
        settings.update(options)
        return OllamaClient("gemma3:4b", standin.url, **settings)

    return make


Send = Callable[[HTTPChatClient, ChatRequest], LLMResult]


def chat(client: HTTPChatClient, request: ChatRequest) -> LLMResult:
    """One call on a fresh event loop, the client's connections closed after it."""

    async def go() -> LLMResult:
        async with client:
            return await client.chat(request)

    return asyncio.run(go())


def structured(client: HTTPChatClient, request: ChatRequest, output: Any, **options: Any) -> LLMResult:
    async def go() -> LLMResult:
        async with client:
            return await chat_structured(client, request, output, **options)

    return asyncio.run(go())


def chat_from_this_thread(client: HTTPChatClient, request: ChatRequest) -> LLMResult:
    """One call through ``chat_sync`` (sent from the calling thread), the client's connections closed after it."""
    with client:
        return client.chat_sync(request)


@pytest.fixture(params=["chat", "chat_sync"])
def send(request: pytest.FixtureRequest) -> Send:
    """A call made both ways, which must behave alike: ``await chat()`` on an event loop, and ``chat_sync()``."""
    sends: dict[str, Send] = {"chat": chat, "chat_sync": chat_from_this_thread}
    return sends[request.param]


def structured_from_this_thread(client: HTTPChatClient, request: ChatRequest, output: Any, **options: Any) -> LLMResult:
    """One structured call through ``chat_structured_sync``, the client's connections closed after it."""
    with client:
        return client.chat_structured_sync(request, output, **options)


Ask = Callable[..., LLMResult]


@pytest.fixture(params=["chat_structured", "chat_structured_sync"])
def ask(request: pytest.FixtureRequest) -> Ask:
    """A structured call made both ways: ``await chat_structured()`` and ``chat_structured_sync()``."""
    asks: dict[str, Ask] = {"chat_structured": structured, "chat_structured_sync": structured_from_this_thread}
    return asks[request.param]
