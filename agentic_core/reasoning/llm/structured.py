"""Structured output: ask for a reply that matches a JSON Schema (a pydantic model's, or one given as a dict),
validate it here whatever the server promised, show a broken reply back to the model once with what is wrong,
and return ``invalid_output`` if the second reply is broken too, for the agent to handle.
"""

from __future__ import annotations

import json
import re
from collections.abc import Generator
from typing import Any, Protocol

import jsonschema
from pydantic import BaseModel, ValidationError

from agentic_core.contracts import json_depth as bounded_json

from .client import LLMClient
from .messages import ChatRequest, Message, ResponseSchema
from .output_cap import cap_text, cap_value, max_output_chars
from .result import LLMResult

FENCE = re.compile(r"^\s*```(?:json)?\s*\n(.*?)\n?\s*```\s*$", re.DOTALL)
MAX_PROBLEMS = 5


def response_schema(
    output: type[BaseModel] | dict[str, Any] | ResponseSchema, name: str | None = None
) -> ResponseSchema:
    """The :class:`ResponseSchema` for a pydantic model, a JSON Schema dict or a ResponseSchema as it is.

    >>> response_schema({"type": "object", "required": ["severity"]}, "assessment").json_schema["required"]
    ['severity']
    """
    if isinstance(output, ResponseSchema):
        return output if name is None else output.model_copy(update={"name": name})
    if isinstance(output, dict):
        return ResponseSchema(name=name or "response", json_schema=output)
    if isinstance(output, type) and issubclass(output, BaseModel):
        return ResponseSchema.from_model(output, name=name)
    raise TypeError(f"expected a pydantic model class, a JSON Schema dict or a ResponseSchema, got {output!r}")


def validate_output(
    content: str | None, output: type[BaseModel] | dict[str, Any] | ResponseSchema, max_chars: int | None = None
) -> tuple[Any, str | None]:
    """``(value, None)`` for a reply that is JSON matching ``output`` (a model instance for a model class), else
    ``(None, what is wrong)``. A reply wrapped in a Markdown code fence is read inside the fence. Its text is
    capped (:mod:`.output_cap`) at ``max_chars`` (default: the cap in force) before it is validated.

    >>> validate_output('{"severity": "high"}', {"type": "object", "required": ["severity"]})
    ({'severity': 'high'}, None)
    >>> validate_output('{"severity": 3}', {"properties": {"severity": {"type": "string"}}})
    (None, "$.severity: 3 is not of type 'string'")
    >>> validate_output("high", {"type": "object"})[1]
    'the reply is not JSON (Expecting value at line 1 column 1)'
    """
    if content is None or not content.strip():
        return None, "the reply is empty; a JSON object was expected"
    fenced = FENCE.match(content)
    text = fenced.group(1) if fenced else content
    try:
        value = bounded_json.loads(text)
    except json.JSONDecodeError as exc:
        return None, f"the reply is not JSON ({exc.msg} at line {exc.lineno} column {exc.colno})"
    except bounded_json.JsonTooDeep as exc:
        return None, f"the reply is not usable: {exc}"
    value = cap_value(value, max_output_chars() if max_chars is None else max_chars)
    if isinstance(output, type) and issubclass(output, BaseModel):
        try:
            return output.model_validate(value), None
        except ValidationError as exc:
            problems = [f"{'.'.join(str(p) for p in e['loc']) or '$'}: {e['msg']}" for e in exc.errors()]
            return None, _join(problems)
    schema = output.json_schema if isinstance(output, ResponseSchema) else output
    errors = sorted(jsonschema.Draft202012Validator(schema).iter_errors(value), key=lambda e: str(e.json_path))
    if errors:
        return None, _join([f"{e.json_path}: {e.message}" for e in errors])
    return value, None


def _join(problems: list[str]) -> str:
    more = f" (and {len(problems) - MAX_PROBLEMS} more)" if len(problems) > MAX_PROBLEMS else ""
    return "; ".join(problems[:MAX_PROBLEMS]) + more


def _combined(first: LLMResult, second: LLMResult, **changes: Any) -> LLMResult:
    """``second`` with the usage, requests and time of both calls."""
    servers = [r.server_s for r in (first, second) if r.server_s is not None]
    return second.model_copy(
        update={
            "usage": first.usage + second.usage,
            "attempts": first.attempts + second.attempts,
            "latency_s": first.latency_s + second.latency_s,
            "server_s": sum(servers) if servers else None,
            **changes,
        }
    )


async def chat_structured(
    client: LLMClient,
    request: ChatRequest,
    output: type[BaseModel] | dict[str, Any] | ResponseSchema,
    *,
    name: str | None = None,
    repairs: int = 1,
) -> LLMResult:
    """Ask ``client`` for a reply matching ``output``; ``result.parsed`` holds the validated value.

    A reply that is not JSON or breaks the schema is sent back to the model ``repairs`` times (once by default)
    with the validation message; then the result is ``invalid_output`` with that message in ``error``. A reply
    that calls tools instead is returned as it is, for the agent to run them.

    >>> import asyncio
    >>> from agentic_core.reasoning.llm import LLMResult
    >>> class Scripted:  # any LLMClient works: here a stand-in that answers from a list
    ...     provider, model = "scripted", "m"
    ...     def __init__(self, *replies): self.replies = list(replies)
    ...     async def chat(self, request):
    ...         return LLMResult(status="ok", content=self.replies.pop(0), model="m", provider="scripted", attempts=1)
    >>> schema = {"type": "object", "properties": {"persons": {"type": "integer"}}, "required": ["persons"]}
    >>> request = ChatRequest(messages=[Message.user("How many persons?")])
    >>> result = asyncio.run(chat_structured(Scripted('{"persons": "two"}', '{"persons": 2}'), request, schema))
    >>> result.status, result.parsed, result.repaired, result.attempts
    ('ok', {'persons': 2}, True, 2)
    """
    exchange = _structured(request, output, name, repairs)
    current = next(exchange)
    while True:
        answer = await client.chat(current)
        try:
            current = exchange.send(answer)
        except StopIteration as done:  # the exchange's own end, not a StopIteration from the client
            result: LLMResult = done.value
            return result


class SyncChat(Protocol):
    """What :func:`chat_structured_sync` needs of a client: a synchronous ``chat_sync``."""

    def chat_sync(self, request: ChatRequest) -> LLMResult: ...


def chat_structured_sync(
    client: SyncChat,
    request: ChatRequest,
    output: type[BaseModel] | dict[str, Any] | ResponseSchema,
    *,
    name: str | None = None,
    repairs: int = 1,
) -> LLMResult:
    """:func:`chat_structured` for synchronous callers, through ``client.chat_sync``."""
    exchange = _structured(request, output, name, repairs)
    current = next(exchange)
    while True:
        answer = client.chat_sync(current)
        try:
            current = exchange.send(answer)
        except StopIteration as done:  # the exchange's own end, not a StopIteration from the client
            result: LLMResult = done.value
            return result


def _structured(
    request: ChatRequest, output: type[BaseModel] | dict[str, Any] | ResponseSchema, name: str | None, repairs: int
) -> Generator[ChatRequest, LLMResult, LLMResult]:
    """The structured call without its input and output: yields each request to chat, is sent each result, and
    returns the final result."""
    schema = response_schema(output, name)
    target = output if isinstance(output, type) else schema
    current = request.model_copy(update={"response_schema": schema})
    result = yield current
    total = result
    limit = max_output_chars()
    for round_ in range(repairs + 1):
        if not result.ok or (result.tool_calls and not (result.content or "").strip()):
            return total
        value, problem = validate_output(result.content, target, limit)
        if problem is None:
            content = cap_text(result.content or "", limit)
            return total.model_copy(
                update={"parsed": value, "content": content, "repaired": round_ > 0 or total.repaired}
            )
        if round_ == repairs:
            what = f" after {repairs} correction{'s' if repairs != 1 else ''}" if repairs else ""
            error = f"the reply does not match the schema {schema.name!r}{what}: {problem}"
            content = cap_text(result.content or "", limit)
            return total.model_copy(update={"status": "invalid_output", "error": error, "content": content})
        feedback = Message.user(
            f"Your reply does not match the required JSON schema {schema.name!r}: {problem}. "
            "Reply again with only the corrected JSON, nothing else."
        )
        current = current.with_messages(Message.assistant(cap_text(result.content or "", limit)), feedback)
        result = yield current
        total = _combined(total, result)
    return total
