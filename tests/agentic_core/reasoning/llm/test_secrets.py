"""API keys come from the environment and never show: not in results, errors, reprs or log lines, even when a
server quotes them back."""

from __future__ import annotations

import logging
from collections.abc import Callable

import pytest

from agentic_core.reasoning.llm import ChatRequest, Message, OpenAICompatibleClient, create_client, parse_llm_spec

from .conftest import KEY, chat
from .standin import StandIn, openai_completion, openai_error

MakeClient = Callable[..., OpenAICompatibleClient]
REQUEST = ChatRequest(messages=[Message.user("hi")])


def assert_hidden(text: str) -> None:
    assert KEY not in text
    assert KEY[8:] not in text  # nor its tail


def test_a_server_quoting_the_key_back(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.DEBUG, logger="agentic_core.reasoning.llm")
    with StandIn(key="sk-the-right-one") as server:
        client = OpenAICompatibleClient("gpt-4o", server.url + "/v1", api_key=KEY, trust_env=False)
        result = chat(client, REQUEST)

    assert result.status == "http_error" and result.http_status == 401
    assert result.error is not None and "Incorrect API key provided: Bearer [redacted]" in result.error
    assert_hidden(result.model_dump_json())
    assert_hidden(repr(result))
    assert_hidden(repr(client))
    assert_hidden(caplog.text)
    assert caplog.text  # the failure was logged, redacted


def test_retried_errors_are_logged_without_the_key(
    standin: StandIn, openai_client: MakeClient, caplog: pytest.LogCaptureFixture
) -> None:
    caplog.set_level(logging.DEBUG, logger="agentic_core.reasoning.llm")
    standin.script(openai_error(500, f"upstream said: key {KEY} failed", type="server_error"), openai_completion("ok"))
    result = chat(openai_client(), REQUEST)
    assert result.ok
    assert "retrying in" in caplog.text and "[redacted]" in caplog.text
    assert_hidden(caplog.text)


def test_a_config_never_shows_its_key() -> None:
    config = parse_llm_spec("openai:gpt-4o", environ={"OPENAI_API_KEY": KEY})
    assert config.api_key is not None and config.api_key.get_secret_value() == KEY
    assert config.api_key_env == "OPENAI_API_KEY"
    assert_hidden(repr(config))
    assert_hidden(config.model_dump_json())
    assert_hidden(config.spec())
    assert_hidden(repr(create_client(config)))


def test_the_key_goes_only_in_the_authorization_header(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("ok"))
    chat(openai_client(), REQUEST)
    [sent] = standin.received
    assert sent.headers["authorization"] == f"Bearer {KEY}"
    assert_hidden(str(sent.body))
