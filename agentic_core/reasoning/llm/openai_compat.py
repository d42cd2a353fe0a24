"""OpenAI's ``POST /v1/chat/completions`` (OpenAI, vLLM, llama.cpp server, LM Studio, Ollama's /v1): tools and
``tool_choice``, ``response_format`` with ``json_schema``, tool results as ``role: tool`` messages with their
``tool_call_id``, images as ``image_url`` parts holding ``data:`` URLs; non-streaming JSON answers.

A reply's tool-call ``arguments`` is JSON text; text that does not parse is a broken call, shown back to the model
once. ``message.refusal`` and ``finish_reason: content_filter`` are refusals.
"""

from __future__ import annotations

import json
from typing import Any, ClassVar, Literal

from agentic_core.contracts import json_depth as bounded_json

from .client import HTTPChatClient, Turn, synthesize_call_id
from .config import LLMConfig
from .messages import ChatRequest, Message, ToolCall
from .result import Usage

MaxTokensField = Literal["max_tokens", "max_completion_tokens"]


def _count(value: Any) -> int:
    return value if isinstance(value, int) and value >= 0 else 0


def _text(content: Any) -> str | None:
    """A reply's content: a string, or (some servers) a list of text parts."""
    if content is None or isinstance(content, str):
        return content
    if isinstance(content, list):
        return "".join(str(part.get("text", "")) for part in content if isinstance(part, dict))
    raise TypeError(f"message.content is {type(content).__name__}, not text")


def parse_arguments(raw: Any) -> tuple[dict[str, Any], str | None, str | None]:
    """``(arguments, raw_text, problem)`` of a tool call's ``arguments``: JSON text in OpenAI's format, an object
    from servers that send one (Ollama's shape); empty text is no arguments."""
    if isinstance(raw, dict):
        return raw, None, None
    if raw is None:
        return {}, None, None
    if not isinstance(raw, str):
        return {}, json.dumps(raw), f"arguments must be a JSON object, got {type(raw).__name__}"
    if not raw.strip():
        return {}, raw, None
    try:
        value = bounded_json.loads(raw)
    except json.JSONDecodeError as exc:
        return {}, raw, f"arguments are not valid JSON ({exc.msg} at line {exc.lineno} column {exc.colno})"
    except bounded_json.JsonTooDeep as exc:
        return {}, raw[:200], f"arguments are not usable: {exc}"
    if not isinstance(value, dict):
        return {}, raw, f"arguments must be a JSON object, got {type(value).__name__}"
    return value, raw, None


class OpenAICompatibleClient(HTTPChatClient):
    """A model behind an OpenAI-compatible chat completions endpoint; ``base_url`` ends with ``/v1``.

    >>> from agentic_core.reasoning.llm import ChatRequest, Message
    >>> client = OpenAICompatibleClient("gpt-4o", "https://api.openai.com/v1", api_key="sk-not-real")
    >>> body = client.request_body(ChatRequest(messages=[Message.user("Anyone near the tent?")], temperature=0))
    >>> body["model"], body["messages"], body["temperature"]
    ('gpt-4o', [{'role': 'user', 'content': 'Anyone near the tent?'}], 0.0)
    >>> client
    OpenAICompatibleClient(provider='openai-compatible', model='gpt-4o', base_url='https://api.openai.com/v1')
    """

    endpoint: ClassVar[str] = "/chat/completions"
    probe_endpoint: ClassVar[str] = "/models"
    wire_format: ClassVar[str] = "chat completions"
    default_provider: ClassVar[str] = "openai-compatible"

    def __init__(self, model: str, base_url: str, *, max_tokens_field: MaxTokensField = "max_tokens", **options: Any):
        super().__init__(model, base_url, **options)
        self.max_tokens_field: MaxTokensField = max_tokens_field

    @classmethod
    def _config_options(cls, config: LLMConfig) -> dict[str, Any]:
        return {"max_tokens_field": config.max_tokens_field}

    # request --------------------------------------------------------------------------------------------------
    def request_body(self, request: ChatRequest) -> dict[str, Any]:
        body: dict[str, Any] = {"model": self.model, "messages": [self._message(m) for m in request.messages]}
        if request.tools:
            body["tools"] = [tool.to_openai() for tool in request.tools]
            if request.tool_choice is not None:
                body["tool_choice"] = self._tool_choice(request.tool_choice)
        schema = request.response_schema
        if schema is not None:
            json_schema: dict[str, Any] = {"name": schema.name, "schema": schema.json_schema, "strict": schema.strict}
            if schema.description:
                json_schema["description"] = schema.description
            body["response_format"] = {"type": "json_schema", "json_schema": json_schema}
        if request.temperature is not None:
            body["temperature"] = request.temperature
        if request.max_tokens is not None:
            body[self.max_tokens_field] = request.max_tokens
        if request.seed is not None:
            body["seed"] = request.seed
        body["stream"] = False
        return body

    @staticmethod
    def _tool_choice(choice: str) -> str | dict[str, Any]:
        if choice in ("auto", "none", "required"):
            return choice
        return {"type": "function", "function": {"name": choice}}

    @staticmethod
    def _message(message: Message) -> dict[str, Any]:
        if message.role == "tool":
            return {"role": "tool", "tool_call_id": message.tool_call_id, "content": message.content or ""}
        if message.role == "assistant":
            entry: dict[str, Any] = {"role": "assistant", "content": message.content}
            if message.tool_calls:
                entry["tool_calls"] = [
                    {
                        "id": call.id,
                        "type": "function",
                        "function": {"name": call.name, "arguments": call.arguments_json()},
                    }
                    for call in message.tool_calls
                ]
            return entry
        if message.images:
            parts: list[dict[str, Any]] = [{"type": "text", "text": message.content or ""}]
            parts += [{"type": "image_url", "image_url": {"url": image.data_url()}} for image in message.images]
            return {"role": message.role, "content": parts}
        return {"role": message.role, "content": message.content}

    # reply ----------------------------------------------------------------------------------------------------
    def read_reply(self, data: dict[str, Any], request: ChatRequest) -> Turn:
        choices = data["choices"]
        if not isinstance(choices, list) or not choices:
            raise ValueError("no choices")
        choice = choices[0]
        message = choice["message"]
        finish_reason = choice.get("finish_reason")
        calls: list[ToolCall] = []
        problems: dict[str, str] = {}
        for index, item in enumerate(message.get("tool_calls") or []):
            function = item["function"]
            name = str(function["name"])
            arguments, raw, problem = parse_arguments(function.get("arguments"))
            call_id = item.get("id") or synthesize_call_id(len(request.messages), index, name, raw or arguments)
            calls.append(ToolCall(id=str(call_id), name=name, arguments=arguments, raw_arguments=raw))
            if problem is not None:
                problems[calls[-1].id] = f"{name}: {problem}"
        refusal = message.get("refusal") or None
        if refusal is None and finish_reason == "content_filter":
            refusal = "the provider's content filter stopped the reply (finish_reason content_filter)"
        usage = data.get("usage") or {}
        return Turn(
            content=_text(message.get("content")),
            tool_calls=calls,
            finish_reason=finish_reason,
            usage=Usage(
                prompt_tokens=_count(usage.get("prompt_tokens")),
                completion_tokens=_count(usage.get("completion_tokens")),
            ),
            model=data.get("model") if isinstance(data.get("model"), str) else None,
            refusal=str(refusal) if refusal is not None else None,
            problems=problems,
        )
