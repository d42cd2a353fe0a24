"""Ollama's native ``POST /api/chat`` with ``stream: false``: tools in OpenAI's function format, structured output
through ``format`` (a JSON Schema), sampling in ``options`` (``temperature``, ``seed``, ``num_predict``) and images
as bare base64 in a message's ``images``.

Its replies differ from OpenAI's: a tool call's ``arguments`` is a JSON object and the call has no id (one is
made up, stable for the same call at the same place in a chat); tool results go back as ``role: tool`` messages
with the tool's ``tool_name``; token counts are ``prompt_eval_count`` and ``eval_count``; errors are
``{"error": "..."}``. Ollama has no ``tool_choice``: ``none`` sends no tools, a tool's name sends only that one.
"""

from __future__ import annotations

from typing import Any, ClassVar

from .client import HTTPChatClient, Turn, synthesize_call_id
from .messages import ChatRequest, Message, ToolCall
from .openai_compat import parse_arguments
from .result import Usage


def _count(value: Any) -> int:
    return value if isinstance(value, int) and value >= 0 else 0


def _nanoseconds(value: Any) -> float | None:
    """A duration Ollama gives in nanoseconds (``total_duration``), in seconds; None when absent or not one."""
    return value / 1e9 if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


class OllamaClient(HTTPChatClient):
    """A model served by Ollama, through its native chat API; ``base_url`` is the server root.

    >>> from agentic_core.reasoning.llm import ChatRequest, Message
    >>> client = OllamaClient("gemma3:4b", "http://localhost:11434")
    >>> body = client.request_body(ChatRequest(messages=[Message.user("Anyone there?")], seed=7, max_tokens=200))
    >>> body["stream"], body["options"]
    (False, {'seed': 7, 'num_predict': 200})
    """

    endpoint: ClassVar[str] = "/api/chat"
    probe_endpoint: ClassVar[str] = "/api/tags"
    wire_format: ClassVar[str] = "Ollama /api/chat"
    default_provider: ClassVar[str] = "ollama"

    # request --------------------------------------------------------------------------------------------------
    def request_body(self, request: ChatRequest) -> dict[str, Any]:
        names = self._call_names(request.messages)
        body: dict[str, Any] = {
            "model": self.model,
            "messages": [self._message(m, names) for m in request.messages],
            "stream": False,
        }
        tools = request.tools
        if request.tool_choice == "none":
            tools = []
        elif request.tool_choice not in (None, "auto", "required"):
            tools = [tool for tool in tools if tool.name == request.tool_choice]
        if tools:
            body["tools"] = [tool.to_openai() for tool in tools]
        if request.response_schema is not None:
            body["format"] = request.response_schema.json_schema
        options: dict[str, Any] = {}
        if request.temperature is not None:
            options["temperature"] = request.temperature
        if request.seed is not None:
            options["seed"] = request.seed
        if request.max_tokens is not None:
            options["num_predict"] = request.max_tokens
        if options:
            body["options"] = options
        return body

    @staticmethod
    def _call_names(messages: list[Message]) -> dict[str, str]:
        """Tool names by call id, for tool messages that did not say which tool answered."""
        return {call.id: call.name for message in messages for call in message.tool_calls}

    @staticmethod
    def _message(message: Message, names: dict[str, str]) -> dict[str, Any]:
        entry: dict[str, Any] = {"role": message.role, "content": message.content or ""}
        if message.role == "tool":
            name = message.name or names.get(message.tool_call_id or "")
            if name:
                entry["tool_name"] = name
        if message.images:
            entry["images"] = [image.data_b64 for image in message.images]
        if message.tool_calls:
            entry["tool_calls"] = [
                {"function": {"name": call.name, "arguments": call.arguments}} for call in message.tool_calls
            ]
        return entry

    # reply ----------------------------------------------------------------------------------------------------
    def read_reply(self, data: dict[str, Any], request: ChatRequest) -> Turn:
        message = data["message"]
        if not isinstance(message, dict):
            raise TypeError("message is not an object")
        calls: list[ToolCall] = []
        problems: dict[str, str] = {}
        for position, item in enumerate(message.get("tool_calls") or []):
            function = item["function"]
            name = str(function["name"])
            index = function.get("index", position)
            arguments, raw, problem = parse_arguments(function.get("arguments"))
            call_id = item.get("id") or synthesize_call_id(len(request.messages), index, name, raw or arguments)
            calls.append(ToolCall(id=str(call_id), name=name, arguments=arguments, raw_arguments=raw))
            if problem is not None:
                problems[calls[-1].id] = f"{name}: {problem}"
        content = message.get("content")
        if not isinstance(content, str | None):
            raise TypeError(f"message.content is {type(content).__name__}, not text")
        return Turn(
            content=None if not content and calls else (content or ""),
            tool_calls=calls,
            finish_reason=data.get("done_reason"),
            usage=Usage(
                prompt_tokens=_count(data.get("prompt_eval_count")), completion_tokens=_count(data.get("eval_count"))
            ),
            model=data.get("model") if isinstance(data.get("model"), str) else None,
            problems=problems,
            server_s=_nanoseconds(data.get("total_duration")),
        )
