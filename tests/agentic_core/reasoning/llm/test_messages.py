"""The neutral request models: messages that fit their role, tool definitions from the registry export, tool
choices that name an offered tool."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from agentic_core.reasoning.llm import ChatRequest, Message, ResponseSchema, ToolCall, ToolDefinition
from tools import ToolResult

from .test_openai import registry


def test_messages_fit_their_role() -> None:
    with pytest.raises(ValidationError, match="a tool message needs the tool_call_id"):
        Message(role="tool", content="x")
    with pytest.raises(ValidationError, match="only assistant messages carry tool_calls"):
        Message(role="user", content="x", tool_calls=[ToolCall(id="c", name="n")])
    with pytest.raises(ValidationError, match="a user message needs content"):
        Message(role="user")
    assert Message.assistant(None, [ToolCall(id="c", name="n")]).content is None


def test_a_tool_result_becomes_json_text() -> None:
    call = ToolCall(id="c1", name="weather__wind", arguments={})
    result = ToolResult(status="ok", output={"speed_mps": 4.2}, latency_s=0.1, attempts=1, call_id="x", tool="w")
    message = Message.tool(call, result)
    assert message.tool_call_id == "c1" and message.name == "weather__wind"
    assert message.content is not None and '"speed_mps":4.2' in message.content
    assert Message.tool(call, "plain").content == "plain"


def test_tools_from_the_registry_export() -> None:
    request = ChatRequest(messages=[Message.user("x")], tools=registry().to_openai())
    assert request.tool_names() == ["flight__land", "weather__wind"]
    assert request.tools[1].parameters["required"] == ["lat", "lon"]
    assert [t.to_openai() for t in request.tools] == registry().to_openai()


def test_dotted_names_are_refused_with_a_hint() -> None:
    with pytest.raises(ValidationError, match=r"tools.openai_name maps 'weather.wind' to 'weather__wind'"):
        ToolDefinition(name="weather.wind")


def test_tool_choice_names_an_offered_tool() -> None:
    with pytest.raises(ValidationError, match="tool_choice 'flight__fly' is not auto, none, required or one of"):
        ChatRequest(messages=[Message.user("x")], tools=registry().to_openai(), tool_choice="flight__fly")


def test_a_response_schema_from_a_model() -> None:
    schema = ResponseSchema.from_model(ToolResult)
    assert schema.name == "ToolResult" and schema.json_schema["title"] == "ToolResult"
    with pytest.raises(ValidationError):
        ResponseSchema(name="has space", json_schema={})
