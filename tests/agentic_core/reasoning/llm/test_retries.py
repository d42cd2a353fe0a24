"""Failures that are results: 429 with Retry-After, 5xx, retries running out, read timeouts, refused
connections, answers that are not the API's format; and the running totals of a client. Each is checked both
ways a call is sent: ``await chat()`` and ``chat_sync()``."""

from __future__ import annotations

import asyncio
import socket
import time
from collections.abc import Callable

import pytest

from agentic_core.reasoning.llm import ChatRequest, Message, OllamaClient, OpenAICompatibleClient, RetryPolicy

from .conftest import RecordingSleep, Send
from .standin import Reply, StandIn, ollama_chat, openai_completion, openai_error

MakeClient = Callable[..., OpenAICompatibleClient]
REQUEST = ChatRequest(messages=[Message.user("Status?")])


def rate_limited(retry_after: str | None = None, **headers: str) -> Reply:
    extra = dict(headers)
    if retry_after is not None:
        extra["Retry-After"] = retry_after
    return openai_error(
        429, "Rate limit reached for gpt-4o on requests per min (RPM)", type="requests", code="rate_limit_exceeded",
        headers=extra,
    )  # fmt: skip


def test_429_then_success_waits_what_retry_after_says(
    standin: StandIn, openai_client: MakeClient, sleep: RecordingSleep, send: Send
) -> None:
    standin.script(rate_limited("1"), openai_completion("ok"))
    result = send(openai_client(), REQUEST)
    assert result.ok and result.attempts == 2 and sleep.delays == [1.0]


def test_retry_after_ms_comes_first(
    standin: StandIn, openai_client: MakeClient, sleep: RecordingSleep, send: Send
) -> None:
    standin.script(rate_limited("7", **{"retry-after-ms": "0"}), openai_completion("ok"))
    assert send(openai_client(), REQUEST).ok
    assert sleep.delays == [0.0]


def test_a_real_wait_is_honoured(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(rate_limited(**{"retry-after-ms": "200"}), openai_completion("ok"))
    started = time.perf_counter()
    result = send(openai_client(sleep=asyncio.sleep), REQUEST)
    assert result.ok and time.perf_counter() - started >= 0.2


def test_500_then_success_backs_off(
    standin: StandIn, openai_client: MakeClient, sleep: RecordingSleep, send: Send
) -> None:
    standin.script(openai_error(500, "The server had an error", type="server_error"), openai_completion("ok"))
    result = send(openai_client(), REQUEST)
    assert result.ok and result.attempts == 2 and sleep.delays == [0.5]


def test_retries_run_out(standin: StandIn, openai_client: MakeClient, sleep: RecordingSleep, send: Send) -> None:
    overloaded = openai_error(503, "The engine is currently overloaded", type="server_error")
    standin.script(overloaded, overloaded, overloaded, openai_completion("too late"))
    result = send(openai_client(), REQUEST)

    assert result.status == "http_error" and result.http_status == 503 and result.attempts == 3
    assert result.error is not None and "The engine is currently overloaded" in result.error
    assert sleep.delays == [0.5, 1.0]  # doubling, no jitter in this policy
    assert len(standin.received) == 3


def test_rate_limited_to_the_end(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(rate_limited("2"), rate_limited("2"), rate_limited("2"))
    result = send(openai_client(), REQUEST)
    assert result.status == "rate_limited" and result.attempts == 3 and result.retry_after_s == 2.0
    assert result.error is not None and "rate_limit_exceeded" in result.error


def test_a_retry_after_too_long_is_not_waited(
    standin: StandIn, openai_client: MakeClient, sleep: RecordingSleep, send: Send
) -> None:
    standin.script(rate_limited("3600"))
    result = send(openai_client(), REQUEST)
    assert result.status == "rate_limited" and result.attempts == 1 and result.retry_after_s == 3600.0
    assert sleep.delays == []


def test_no_quota_is_not_retried(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(openai_error(429, "You exceeded your current quota", type="insufficient_quota",
                                code="insufficient_quota"))  # fmt: skip
    result = send(openai_client(), REQUEST)
    assert result.status == "rate_limited" and result.attempts == 1 and result.retry_after_s is None


def test_a_bad_request_is_not_retried(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(openai_error(400, "Invalid value for 'temperature'", param="temperature"))
    result = send(openai_client(), REQUEST)
    assert result.status == "http_error" and result.attempts == 1 and result.http_status == 400


def test_a_stalled_server_is_a_timeout(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(Reply(body={}, stall_s=10))
    started = time.perf_counter()
    result = send(openai_client(read_timeout_s=0.3), REQUEST)
    assert result.status == "timeout" and result.attempts == 1
    assert result.error is not None and "no answer from" in result.error and "0.3 s" in result.error
    assert time.perf_counter() - started < 5


def test_timeouts_are_retried_when_asked(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(Reply(body={}, stall_s=10), openai_completion("ok"))
    policy = RetryPolicy(attempts=2, initial_s=0, jitter_s=0, retry_timeouts=True)
    result = send(openai_client(read_timeout_s=0.3, retry=policy), REQUEST)
    assert result.ok and result.attempts == 2


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
    return port  # closed again: nothing listens there


@pytest.mark.parametrize("kind", [OpenAICompatibleClient, OllamaClient])
def test_a_refused_connection(
    kind: type[OpenAICompatibleClient | OllamaClient], sleep: RecordingSleep, send: Send
) -> None:
    client = kind("m", f"http://127.0.0.1:{free_port()}", sleep=sleep, trust_env=False,
                  retry=RetryPolicy(attempts=3, initial_s=0.1, jitter_s=0))  # fmt: skip
    result = send(client, REQUEST)
    assert result.status == "connection" and result.attempts == 3 and sleep.delays == [0.1, 0.2]
    assert result.error is not None and "cannot connect to http://127.0.0.1:" in result.error
    assert result.model == "m" and result.usage.total_tokens == 0


def test_an_answer_that_is_not_json(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(Reply(text="<html>Bad gateway</html>"))
    result = send(openai_client(), REQUEST)
    assert result.status == "http_error" and result.error is not None and "is not JSON" in result.error


def test_an_answer_that_is_not_a_completion(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(Reply(body={"object": "list", "data": []}))
    result = send(openai_client(), REQUEST)
    assert result.status == "http_error"
    assert result.error is not None and "is not a chat completions reply" in result.error


def test_an_ollama_answer_that_is_not_a_chat(
    standin: StandIn, ollama_client: Callable[..., OllamaClient], send: Send
) -> None:
    standin.script(Reply(body={"model": "gemma3:4b", "response": "hi", "done": True}))  # /api/generate's shape
    result = send(ollama_client(), REQUEST)
    assert result.status == "http_error" and result.error is not None and "Ollama /api/chat" in result.error


def test_totals_add_up(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(
        openai_completion("a", prompt_tokens=10, completion_tokens=2),
        openai_error(500, "boom", type="server_error"),
        openai_completion("b", prompt_tokens=5, completion_tokens=1),
        openai_error(400, "bad"),
    )
    client = openai_client()
    results = [send(client, REQUEST) for _ in range(3)]
    totals = client.totals
    assert [r.status for r in results] == ["ok", "ok", "http_error"]
    assert (totals.calls, totals.failures, totals.attempts) == (3, 1, 4)
    assert (totals.prompt_tokens, totals.completion_tokens, totals.total_tokens) == (15, 3, 18)
    assert totals.latency_s == pytest.approx(sum(r.latency_s for r in results))
    assert client.reset_totals() == totals and client.totals.calls == 0


def test_the_ollama_stand_in_answers_too(
    standin: StandIn, ollama_client: Callable[..., OllamaClient], send: Send
) -> None:
    standin.script(Reply(status=503, body={"error": "server busy"}, headers={"Retry-After": "0"}), ollama_chat("ok"))
    assert send(ollama_client(), REQUEST).ok
