"""The OpenAI-compatible client against the stand-in: the request it writes, the replies it reads, tool calls and
their results, broken arguments shown back to the model once, refusals."""

from __future__ import annotations

import json
from collections.abc import Callable

from agentic_core.reasoning.llm import ChatRequest, Image, Message, OpenAICompatibleClient, ToolCall, create_client
from tools import ToolRegistry

from .conftest import KEY, Send, chat
from .standin import StandIn, openai_call, openai_completion, openai_error

MakeClient = Callable[..., OpenAICompatibleClient]


def registry() -> ToolRegistry:
    tools = ToolRegistry()

    @tools.tool(name="weather.wind")
    def wind(lat: float, lon: float) -> dict[str, float]:
        """Wind at a place, in m/s."""
        return {"speed_mps": 4.2}

    @tools.tool(name="flight.land")
    def land() -> bool:
        """Land where the vehicle is."""
        return True

    return tools


def test_a_text_round_trip(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("No one near the tent.", prompt_tokens=31, completion_tokens=6))
    request = ChatRequest(
        messages=[Message.system("You fly a drone."), Message.user("Anyone near the tent?")],
        temperature=0.2,
        max_tokens=300,
        seed=11,
    )
    result = chat(openai_client(), request)

    assert result.status == "ok" and result.ok
    assert result.content == "No one near the tent." and result.tool_calls == []
    assert result.finish_reason == "stop"
    assert (result.usage.prompt_tokens, result.usage.completion_tokens, result.usage.total_tokens) == (31, 6, 37)
    assert result.model == "gpt-4o-2024-08-06" and result.provider == "openai-compatible"
    assert result.attempts == 1 and result.latency_s > 0 and result.error is None
    [sent] = standin.received
    assert sent.path == "/v1/chat/completions"
    assert sent.headers["authorization"] == f"Bearer {KEY}"
    assert sent.body == {
        "model": "gpt-4o",
        "messages": [
            {"role": "system", "content": "You fly a drone."},
            {"role": "user", "content": "Anyone near the tent?"},
        ],
        "temperature": 0.2,
        "max_tokens": 300,
        "seed": 11,
        "stream": False,
    }


def test_openai_itself_gets_max_completion_tokens(standin: StandIn) -> None:
    client = create_client(f"openai:gpt-4o@{standin.url}/v1", environ={"OPENAI_API_KEY": KEY}, trust_env=False)
    standin.script(openai_completion("ok"))
    assert chat(client, ChatRequest(messages=[Message.user("hi")], max_tokens=50)).ok
    body = standin.received[0].body
    assert body["max_completion_tokens"] == 50 and "max_tokens" not in body
    assert client.provider == "openai"


def test_tool_calls_and_their_results_round_trip(standin: StandIn, openai_client: MakeClient) -> None:
    tools = registry()
    standin.script(
        openai_completion(tool_calls=[openai_call("weather__wind", '{"lat": 21.42, "lon": 39.83}', "call_Wx1")]),
        openai_completion("Wind is 4.2 m/s: safe to fly."),
    )
    client = openai_client()
    request = ChatRequest(
        messages=[Message.user("Is it safe to fly?")], tools=tools.to_openai(), tool_choice="required"
    )
    first = chat(client, request)

    assert first.ok and first.finish_reason == "tool_calls" and first.content is None
    assert first.tool_calls == [
        ToolCall(id="call_Wx1", name="weather__wind", arguments={"lat": 21.42, "lon": 39.83},
                 raw_arguments='{"lat": 21.42, "lon": 39.83}')
    ]  # fmt: skip
    assert tools.resolve(first.tool_calls[0].name) == "weather.wind"
    sent = standin.received[0].body
    assert sent["tool_choice"] == "required"
    assert sent["tools"] == tools.to_openai()

    call = first.tool_calls[0]
    second = chat(client, request.with_messages(first.assistant_message(), Message.tool(call, {"speed_mps": 4.2})))

    assert second.ok and second.content == "Wind is 4.2 m/s: safe to fly."
    history = standin.received[1].body["messages"]
    assert history[1] == {
        "role": "assistant",
        "content": None,
        "tool_calls": [
            {
                "id": "call_Wx1",
                "type": "function",
                "function": {"name": "weather__wind", "arguments": '{"lat": 21.42, "lon": 39.83}'},
            }
        ],
    }
    assert history[2] == {"role": "tool", "tool_call_id": "call_Wx1", "content": '{"speed_mps": 4.2}'}
    assert client.totals.calls == 2 and client.totals.total_tokens == 34


def test_a_named_tool_choice_and_a_response_format(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion(tool_calls=[openai_call("flight__land", "{}")]))
    request = ChatRequest(
        messages=[Message.user("Land now.")], tools=registry().to_openai(), tool_choice="flight__land"
    )
    result = chat(openai_client(), request)

    assert result.ok and result.tool_calls[0].arguments == {}
    assert standin.received[0].body["tool_choice"] == {"type": "function", "function": {"name": "flight__land"}}


def test_images_are_sent_as_data_urls(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("Two persons."))
    image = Image.from_bytes(b"\x89PNG\r\n", "image/png")
    assert chat(openai_client(), ChatRequest(messages=[Message.user("Count persons.", [image])])).ok
    [message] = standin.received[0].body["messages"]
    assert message == {
        "role": "user",
        "content": [
            {"type": "text", "text": "Count persons."},
            {"type": "image_url", "image_url": {"url": "data:image/png;base64,iVBORw0K"}},
        ],
    }


def test_malformed_arguments_are_shown_back_once_and_fixed(
    standin: StandIn, openai_client: MakeClient, send: Send
) -> None:
    standin.script(
        openai_completion(
            tool_calls=[openai_call("weather__wind", '{"lat": 21.42, "lon": ', "call_bad"),
                        openai_call("flight__land", "{}", "call_ok")],
            prompt_tokens=10, completion_tokens=4,
        ),
        openai_completion(tool_calls=[openai_call("weather__wind", '{"lat": 21.42, "lon": 39.83}', "call_good")],
                          prompt_tokens=20, completion_tokens=4),
    )  # fmt: skip
    request = ChatRequest(messages=[Message.user("Check the wind.")], tools=registry().to_openai())
    result = send(openai_client(), request)

    assert result.ok and result.repaired
    assert [c.id for c in result.tool_calls] == ["call_good"]
    assert result.attempts == 2 and result.usage.prompt_tokens == 30 and result.usage.completion_tokens == 8
    repair = standin.received[1].body["messages"]
    assert repair[1]["tool_calls"][0]["function"]["arguments"] == '{"lat": 21.42, "lon": '  # as the model wrote it
    assert repair[2]["tool_call_id"] == "call_bad" and "not valid JSON" in repair[2]["content"]
    assert repair[3]["tool_call_id"] == "call_ok" and repair[3]["content"].startswith("not run")


def test_malformed_twice_is_invalid_output(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    broken = openai_completion(tool_calls=[openai_call("weather__wind", "lat=21.42", "call_bad")])
    standin.script(broken, broken)
    result = send(openai_client(), ChatRequest(messages=[Message.user("Wind?")], tools=registry().to_openai()))

    assert result.status == "invalid_output" and not result.ok
    assert result.error is not None and "after 1 correction:" in result.error and "not valid JSON" in result.error
    assert result.attempts == 2
    assert result.tool_calls[0].raw_arguments == "lat=21.42" and result.tool_calls[0].arguments == {}


def test_arguments_are_checked_against_the_tool_schema(standin: StandIn, openai_client: MakeClient, send: Send) -> None:
    standin.script(
        openai_completion(tool_calls=[openai_call("weather__wind", {"lat": "north", "lon": 39.8}, "c1")]),
        openai_completion(tool_calls=[openai_call("weather__gust", {}, "c2")]),
    )
    client = openai_client(repair_attempts=1)
    result = send(client, ChatRequest(messages=[Message.user("Wind?")], tools=registry().to_openai()))

    assert result.status == "invalid_output"
    repair_message = standin.received[1].body["messages"][2]["content"]
    assert "$.lat: 'north' is not of type 'number'" in repair_message
    assert result.error is not None and "weather__gust: there is no such tool" in result.error


def test_without_repair_a_broken_call_fails_at_once(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion(tool_calls=[openai_call("weather__wind", "[1, 2]", "c1")]))
    result = chat(
        openai_client(repair_attempts=0), ChatRequest(messages=[Message.user("x")], tools=registry().to_openai())
    )
    assert result.status == "invalid_output" and result.attempts == 1
    assert result.error is not None and "must be a JSON object, got list" in result.error


def test_object_arguments_without_an_id_are_normalised(standin: StandIn, openai_client: MakeClient) -> None:
    # the broken-but-observed variant some OpenAI-compatible servers send
    call = {"type": "function", "function": {"name": "weather__wind", "arguments": {"lat": 1.0, "lon": 2.0}}}
    standin.script(openai_completion(tool_calls=[call]))
    result = chat(openai_client(), ChatRequest(messages=[Message.user("x")], tools=registry().to_openai()))
    assert result.ok
    [normalised] = result.tool_calls
    assert normalised.arguments == {"lat": 1.0, "lon": 2.0} and normalised.id.startswith("call_")


def test_a_refusal(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion(None, refusal="I can't help with that."))
    result = chat(openai_client(), ChatRequest(messages=[Message.user("x")]))
    assert result.status == "refusal" and result.error == "the model refused: I can't help with that."
    assert result.finish_reason == "stop"


def test_a_content_filter_stop_is_a_refusal(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_completion("", finish_reason="content_filter"))
    result = chat(openai_client(), ChatRequest(messages=[Message.user("x")]))
    assert result.status == "refusal" and result.finish_reason == "content_filter"
    assert result.error is not None and "content filter" in result.error


def test_an_error_answer_is_read_in_openais_shape(standin: StandIn, openai_client: MakeClient) -> None:
    standin.script(openai_error(404, "The model `gpt-9` does not exist", code="model_not_found"))
    result = chat(openai_client(), ChatRequest(messages=[Message.user("x")]))
    assert result.status == "http_error" and result.http_status == 404 and result.attempts == 1
    assert result.error is not None
    assert "The model `gpt-9` does not exist (invalid_request_error, model_not_found)" in result.error


def test_the_standin_refuses_what_openai_refuses(standin: StandIn, openai_client: MakeClient) -> None:
    # a tool result whose call is not in the history: the 400 comes back as a result, not an exception
    request = ChatRequest(messages=[Message.user("x"), Message.tool("call_nowhere", "done")])
    result = chat(openai_client(), request)
    assert result.status == "http_error" and result.http_status == 400
    assert result.error is not None and "must answer a preceding message with 'tool_calls'" in result.error
    assert json.loads(json.dumps(standin.received[0].body))["messages"][1]["tool_call_id"] == "call_nowhere"
