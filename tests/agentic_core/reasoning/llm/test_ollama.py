"""The Ollama client against the stand-in: /api/chat with stream false, options and format, tool calls with
object arguments and no id normalised to the same ToolCall as OpenAI's, tool results with tool_name."""

from __future__ import annotations

from collections.abc import Callable

from agentic_core.reasoning.llm import ChatRequest, Image, Message, OllamaClient, OpenAICompatibleClient, ResponseSchema

from .conftest import Send, chat
from .standin import StandIn, ollama_call, ollama_chat, ollama_error, openai_call, openai_completion
from .test_openai import registry

MakeOllama = Callable[..., OllamaClient]
MakeOpenAI = Callable[..., OpenAICompatibleClient]


def test_a_text_round_trip(standin: StandIn, ollama_client: MakeOllama) -> None:
    standin.script(ollama_chat("Nobody is at the tent.", prompt_eval_count=40, eval_count=7, done_reason="stop"))
    request = ChatRequest(
        messages=[Message.system("You fly a drone."), Message.user("Anyone there?")],
        temperature=0,
        seed=3,
        max_tokens=128,
    )
    result = chat(ollama_client(), request)

    assert result.ok and result.content == "Nobody is at the tent."
    assert result.finish_reason == "stop" and result.model == "gemma3:4b" and result.provider == "ollama"
    assert (result.usage.prompt_tokens, result.usage.completion_tokens) == (40, 7)
    [sent] = standin.received
    assert sent.path == "/api/chat" and "authorization" not in sent.headers
    assert sent.body == {
        "model": "gemma3:4b",
        "messages": [
            {"role": "system", "content": "You fly a drone."},
            {"role": "user", "content": "Anyone there?"},
        ],
        "stream": False,
        "options": {"temperature": 0.0, "seed": 3, "num_predict": 128},
    }


def test_structured_output_goes_in_format(standin: StandIn, ollama_client: MakeOllama) -> None:
    schema = {"type": "object", "properties": {"persons": {"type": "integer"}}, "required": ["persons"]}
    standin.script(ollama_chat('{"persons": 2}'))
    request = ChatRequest(
        messages=[Message.user("Count.")], response_schema=ResponseSchema(name="c", json_schema=schema)
    )
    assert chat(ollama_client(), request).content == '{"persons": 2}'
    assert standin.received[0].body["format"] == schema


def test_both_formats_give_the_same_tool_call(
    standin: StandIn, ollama_client: MakeOllama, openai_client: MakeOpenAI
) -> None:
    tools = registry().to_openai()
    request = ChatRequest(messages=[Message.user("Wind at the camp?")], tools=tools)
    standin.script(
        ollama_chat(tool_calls=[ollama_call("weather__wind", {"lat": 21.42, "lon": 39.83})]),
        openai_completion(tool_calls=[openai_call("weather__wind", '{"lat": 21.42, "lon": 39.83}', "call_x")]),
    )
    from_ollama = chat(ollama_client(), request)
    from_openai = chat(openai_client(), request)

    assert from_ollama.ok and from_openai.ok
    [a], [b] = from_ollama.tool_calls, from_openai.tool_calls
    assert (a.name, a.arguments) == (b.name, b.arguments) == ("weather__wind", {"lat": 21.42, "lon": 39.83})
    assert a.id.startswith("call_") and a.raw_arguments is None  # an object came: no text to keep
    assert from_ollama.content is None
    assert standin.received[0].body["tools"] == tools


def test_made_up_ids_are_stable_and_distinct(standin: StandIn, ollama_client: MakeOllama) -> None:
    calls = [ollama_call("flight__land", {}), ollama_call("flight__land", {})]
    standin.script(ollama_chat(tool_calls=calls), ollama_chat(tool_calls=calls))
    request = ChatRequest(messages=[Message.user("Land.")], tools=registry().to_openai())
    first, again = chat(ollama_client(), request), chat(ollama_client(), request)

    ids = [c.id for c in first.tool_calls]
    assert len(set(ids)) == 2  # two calls in one reply: two ids
    assert ids == [c.id for c in again.tool_calls]  # the same reply at the same place: the same ids


def test_tool_results_go_back_with_tool_name(standin: StandIn, ollama_client: MakeOllama) -> None:
    standin.script(
        ollama_chat(tool_calls=[ollama_call("weather__wind", {"lat": 1.0, "lon": 2.0})]),
        ollama_chat("Calm: 4.2 m/s."),
    )
    client = ollama_client()
    request = ChatRequest(messages=[Message.user("Wind?")], tools=registry().to_openai())
    first = chat(client, request)
    [call] = first.tool_calls
    result_message = Message.tool(call.id, {"speed_mps": 4.2})  # by id only: the name is found in the history
    second = chat(client, request.with_messages(first.assistant_message(), result_message))

    assert second.ok and second.content == "Calm: 4.2 m/s."
    history = standin.received[1].body["messages"]
    assert history[1] == {
        "role": "assistant",
        "content": "",
        "tool_calls": [{"function": {"name": "weather__wind", "arguments": {"lat": 1.0, "lon": 2.0}}}],
    }
    assert history[2] == {"role": "tool", "content": '{"speed_mps": 4.2}', "tool_name": "weather__wind"}


def test_tool_choice_has_no_ollama_field(standin: StandIn, ollama_client: MakeOllama) -> None:
    standin.script(ollama_chat("no tools"), ollama_chat("one tool"))
    tools = registry().to_openai()
    base = ChatRequest(messages=[Message.user("x")], tools=tools)
    chat(ollama_client(), base.model_copy(update={"tool_choice": "none"}))
    chat(ollama_client(), base.model_copy(update={"tool_choice": "flight__land"}))

    none, named = (request.body for request in standin.received)
    assert "tools" not in none and "tool_choice" not in none
    assert [t["function"]["name"] for t in named["tools"]] == ["flight__land"] and "tool_choice" not in named


def test_images_are_sent_as_base64(standin: StandIn, ollama_client: MakeOllama) -> None:
    standin.script(ollama_chat("A tent."))
    image = Image.from_bytes(b"\xff\xd8\xff\xe0", "image/jpeg")
    assert chat(ollama_client(), ChatRequest(messages=[Message.user("What is this?", [image])])).ok
    assert standin.received[0].body["messages"][0]["images"] == ["/9j/4A=="]


def test_text_arguments_from_ollama_are_parsed_or_repaired(
    standin: StandIn, ollama_client: MakeOllama, send: Send
) -> None:
    standin.script(
        ollama_chat(tool_calls=[ollama_call("weather__wind", '{"lat": 1.0,')]),
        ollama_chat(tool_calls=[ollama_call("weather__wind", '{"lat": 1.0, "lon": 2.0}')]),
    )
    result = send(ollama_client(), ChatRequest(messages=[Message.user("Wind?")], tools=registry().to_openai()))
    assert result.ok and result.repaired and result.tool_calls[0].arguments == {"lat": 1.0, "lon": 2.0}
    repair = standin.received[1].body["messages"]
    assert repair[1]["tool_calls"][0]["function"]["arguments"] == {}  # Ollama takes objects only
    assert repair[2]["tool_name"] == "weather__wind" and "not valid JSON" in repair[2]["content"]


def test_an_ollama_error_is_read(standin: StandIn, ollama_client: MakeOllama) -> None:
    standin.script(ollama_error(404, "model 'gemma3:4b' not found, try pulling it first"))
    result = chat(ollama_client(), ChatRequest(messages=[Message.user("x")]))
    assert result.status == "http_error" and result.http_status == 404 and result.attempts == 1
    assert result.error is not None and result.error.endswith("model 'gemma3:4b' not found, try pulling it first")


def test_a_server_error_then_success(standin: StandIn, ollama_client: MakeOllama, send: Send) -> None:
    standin.script(ollama_error(500, "llama runner process has terminated"), ollama_chat("ok"))
    result = send(ollama_client(), ChatRequest(messages=[Message.user("x")]))
    assert result.ok and result.attempts == 2
