"""``warm()``: a client opens its connection before the first call with one GET of the server's model list, and
says (never raises) when the server does not answer; the key never shows in what it says."""

from __future__ import annotations

import socket
from collections.abc import Callable

from agentic_core.reasoning.llm import ChatRequest, Message, OllamaClient, OpenAICompatibleClient

from .conftest import KEY
from .standin import StandIn, openai_completion


def test_an_openai_compatible_client_probes_its_model_list_then_calls_on_the_same_connection(
    standin: StandIn, openai_client: Callable[..., OpenAICompatibleClient]
) -> None:
    client = openai_client()
    standin.key = KEY
    try:
        assert client.warm() is None and standin.probes == ["/v1/models"]
        standin.script(openai_completion("ready"))
        assert client.chat_sync(ChatRequest(messages=[Message.user("there?")])).content == "ready"
        assert len(standin.received) == 1  # the probe is not a chat request
    finally:
        client.close()


def test_an_ollama_client_probes_its_tags(standin: StandIn, ollama_client: Callable[..., OllamaClient]) -> None:
    client = ollama_client()
    try:
        assert client.warm() is None and standin.probes == ["/api/tags"]
    finally:
        client.close()


def test_a_refused_key_or_no_server_is_said_not_raised(
    standin: StandIn, openai_client: Callable[..., OpenAICompatibleClient]
) -> None:
    standin.key = "sk-the-right-one"
    client = openai_client()
    try:
        refused = client.warm()
        assert refused is not None and "401" in refused and KEY not in refused and "[redacted]" in refused
    finally:
        client.close()
    with socket.socket() as sock:  # a port nothing listens on
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    silent = OpenAICompatibleClient("m", f"http://127.0.0.1:{port}/v1", trust_env=False, connect_timeout_s=1.0)
    try:
        said = silent.warm()
        assert said is not None and said.startswith(f"cannot reach http://127.0.0.1:{port}")
    finally:
        silent.close()
