"""What goes to a model: messages, images, tool definitions and calls, and the chat request, in one neutral form
that each client writes in its own wire format (OpenAI's chat completions or Ollama's /api/chat).

Tool definitions take the project's registry export as it is (``ChatRequest(tools=registry.to_openai())``); the
model calls them by that exported name (``weather__get_forecast``), which ``ToolRegistry.resolve`` maps back.
"""

from __future__ import annotations

import base64
import functools
import json
import re
from typing import Any, Literal, Self

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from tools.security import wrap_untrusted

Role = Literal["system", "user", "assistant", "tool"]
ToolChoiceKeyword = Literal["auto", "none", "required"]
NAME_PATTERN = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
"""Names OpenAI accepts for functions and response schemas (Ollama accepts them too)."""


class Image(BaseModel):
    """An image for a vision model: base64 data and its media type. OpenAI gets it as a ``data:`` URL, Ollama as
    the bare base64 in ``images``.

    >>> Image.from_bytes(b"\\x89PNG", "image/png").data_url()
    'data:image/png;base64,iVBORw=='
    """

    model_config = ConfigDict(frozen=True)

    media_type: str = Field(default="image/png", pattern=r"^image/[A-Za-z0-9.+-]+$")
    data_b64: str = Field(min_length=1, description="the image bytes, base64-encoded (no data: prefix)")

    @classmethod
    def from_bytes(cls, data: bytes, media_type: str = "image/png") -> Image:
        return cls(media_type=media_type, data_b64=base64.b64encode(data).decode("ascii"))

    def data_url(self) -> str:
        return f"data:{self.media_type};base64,{self.data_b64}"


class ToolCall(BaseModel):
    """A call the model asked for, the same whichever server answered: OpenAI's string arguments and Ollama's
    object arguments both end up as the ``arguments`` dict; Ollama's calls, which have no id, get a stable one.

    ``raw_arguments`` keeps the text as the model wrote it when it came as a string, so a malformed one can be
    shown back to the model.

    >>> ToolCall(id="call_1", name="weather__wind", arguments={"lat": 21.4}).arguments["lat"]
    21.4
    """

    model_config = ConfigDict(frozen=True)

    id: str = Field(min_length=1)
    name: str = Field(min_length=1, description="the name the model used: a tool's exported (OpenAI) name")
    arguments: dict[str, Any] = Field(default_factory=dict)
    raw_arguments: str | None = Field(default=None, description="the arguments as received, when they were text")

    def arguments_json(self) -> str:
        """The arguments as JSON text: the model's own text when it sent text, else the dict serialised."""
        if self.raw_arguments is not None:
            return self.raw_arguments
        return json.dumps(self.arguments, ensure_ascii=False)


def _tool_content(value: Any, untrusted: bool, source: str | None) -> str:
    if isinstance(value, str):
        text = value
    elif isinstance(value, BaseModel):
        text = value.model_dump_json()
        untrusted = untrusted or getattr(value, "untrusted", False) is True  # a ToolResult the executor marked
        source = getattr(value, "tool", None) or source
    else:
        text = json.dumps(value, ensure_ascii=False, default=str)
    return wrap_untrusted(text, source=f"the tool {source or 'unknown'}") if untrusted else text


class Message(BaseModel):
    """One message of a chat. Build them with :meth:`system`, :meth:`user`, :meth:`assistant` and :meth:`tool`.

    >>> Message.user("Is anyone at the tent?").role
    'user'
    >>> call = ToolCall(id="call_1", name="flight__land")
    >>> Message.tool(call, {"landed": True}).content
    '{"landed": true}'
    """

    model_config = ConfigDict(frozen=True)

    role: Role
    content: str | None = None
    images: list[Image] = Field(default_factory=list, description="for user messages, to vision models")
    tool_calls: list[ToolCall] = Field(default_factory=list, description="for assistant messages")
    tool_call_id: str | None = Field(default=None, description="for tool messages: the call this answers")
    name: str | None = Field(default=None, description="for tool messages: the tool's name (Ollama's tool_name)")

    @model_validator(mode="after")
    def _fields_fit_the_role(self) -> Self:
        if self.role == "tool" and not self.tool_call_id:
            raise ValueError("a tool message needs the tool_call_id of the call it answers")
        if self.role != "tool" and (self.tool_call_id is not None or self.name is not None):
            raise ValueError("tool_call_id and name belong to tool messages")
        if self.tool_calls and self.role != "assistant":
            raise ValueError("only assistant messages carry tool_calls")
        if self.images and self.role != "user":
            raise ValueError("only user messages carry images")
        if self.content is None and not self.tool_calls:
            raise ValueError(f"a {self.role} message needs content")
        return self

    @classmethod
    def system(cls, text: str) -> Message:
        return cls(role="system", content=text)

    @classmethod
    def user(cls, text: str, images: list[Image] | tuple[Image, ...] = ()) -> Message:
        return cls(role="user", content=text, images=list(images))

    @classmethod
    def assistant(cls, text: str | None = None, tool_calls: list[ToolCall] | tuple[ToolCall, ...] = ()) -> Message:
        return cls(role="assistant", content=text, tool_calls=list(tool_calls))

    @classmethod
    def tool(cls, call: ToolCall | str, output: Any, *, name: str | None = None, untrusted: bool = False) -> Message:
        """The answer to a tool call: ``output`` as text (a string as it is, anything else as JSON, a pydantic
        model such as a ``ToolResult`` by its JSON dump). Untrusted output (``untrusted=True``, or a ``ToolResult``
        the executor marked untrusted) is fenced as data (``tools.security.wrap_untrusted``)."""
        tool_name = name or (call.name if isinstance(call, ToolCall) else None)
        content = _tool_content(output, untrusted, tool_name)
        if isinstance(call, ToolCall):
            return cls(role="tool", content=content, tool_call_id=call.id, name=tool_name)
        return cls(role="tool", content=content, tool_call_id=call, name=name)


class ToolDefinition(BaseModel):
    """A tool the model may call: its exported name, a description and the JSON Schema of its arguments.

    >>> from_registry = {"type": "function", "function": {"name": "math__add", "description": "Add.",
    ...     "parameters": {"type": "object", "properties": {"a": {"type": "integer"}}}}}
    >>> ToolDefinition.from_openai(from_registry).name
    'math__add'
    """

    model_config = ConfigDict(frozen=True)

    name: str
    description: str = ""
    parameters: dict[str, Any] = Field(default_factory=lambda: {"type": "object", "properties": {}})

    @field_validator("name")
    @classmethod
    def _exported_name(cls, name: str) -> str:
        if not NAME_PATTERN.match(name):
            raise ValueError(
                f"tool name {name!r} is not one a model API accepts (letters, digits, _ and -, at most 64): "
                "pass the registry's export (tools.openai_name maps 'weather.wind' to 'weather__wind')"
            )
        return name

    @classmethod
    def from_openai(cls, entry: dict[str, Any]) -> ToolDefinition:
        """One entry of OpenAI's ``tools`` list, as ``ToolRegistry.to_openai()`` exports it."""
        if entry.get("type") != "function" or not isinstance(entry.get("function"), dict):
            raise ValueError(f"not a function tool in OpenAI's format: {entry!r}")
        function = entry["function"]
        return cls(
            name=function.get("name", ""),
            description=function.get("description") or "",
            parameters=function.get("parameters") or {"type": "object", "properties": {}},
        )

    def to_openai(self) -> dict[str, Any]:
        return {
            "type": "function",
            "function": {"name": self.name, "description": self.description, "parameters": self.parameters},
        }


class ResponseSchema(BaseModel):
    """Structured output: the JSON Schema the model's reply must match, with a name (OpenAI requires one).

    ``strict`` asks OpenAI for exact adherence, which accepts only a subset of JSON Schema (every property
    required, ``additionalProperties: false``); the reply is validated here either way.

    >>> ResponseSchema(name="assessment", json_schema={"type": "object"}).name
    'assessment'
    """

    model_config = ConfigDict(frozen=True, populate_by_name=True)

    name: str = Field(pattern=NAME_PATTERN.pattern)
    json_schema: dict[str, Any] = Field(alias="schema")
    description: str | None = None
    strict: bool = False

    @classmethod
    def from_model(cls, model: type[BaseModel], *, name: str | None = None, strict: bool = False) -> ResponseSchema:
        """The schema of a pydantic model, made once per model, name and ``strict`` and shared after (generating
        a model's JSON Schema takes about a millisecond, on the way from a critical frame to its assessment): it is
        frozen, and its ``json_schema`` is to be read, not changed."""
        return _model_schema(cls, model, name, strict)


@functools.cache
def _model_schema(cls: type[ResponseSchema], model: type[BaseModel], name: str | None, strict: bool) -> ResponseSchema:
    schema_name = name or re.sub(r"[^A-Za-z0-9_-]", "_", model.__name__)[:64]
    return cls(name=schema_name, json_schema=model.model_json_schema(), description=model.__doc__, strict=strict)


class ChatRequest(BaseModel):
    """One turn of a chat: the messages so far, the tools on offer and how to answer.

    ``tool_choice`` is ``auto``, ``none``, ``required`` or the name of one of ``tools`` (Ollama has no such
    control: ``none`` sends no tools, a name sends only that tool, the rest send all of them).

    >>> request = ChatRequest(messages=[Message.user("hi")], temperature=0, seed=7)
    >>> request.messages[0].content, request.tools
    ('hi', [])
    """

    model_config = ConfigDict(frozen=True)

    messages: list[Message] = Field(min_length=1)
    tools: list[ToolDefinition] = Field(default_factory=list)
    tool_choice: str | None = None
    response_schema: ResponseSchema | None = None
    temperature: float | None = Field(default=None, ge=0, le=2)
    max_tokens: int | None = Field(default=None, gt=0)
    seed: int | None = None

    @field_validator("tools", mode="before")
    @classmethod
    def _accept_registry_export(cls, value: Any) -> Any:
        if isinstance(value, list | tuple):
            return [
                ToolDefinition.from_openai(item) if isinstance(item, dict) and "function" in item else item
                for item in value
            ]
        return value

    @model_validator(mode="after")
    def _choice_names_a_tool(self) -> Self:
        choice = self.tool_choice
        if choice is None or choice in ("auto", "none", "required"):
            return self
        names = [tool.name for tool in self.tools]
        if choice not in names:
            raise ValueError(f"tool_choice {choice!r} is not auto, none, required or one of the tools {names}")
        return self

    def with_messages(self, *more: Message) -> ChatRequest:
        """This request with messages appended (the next turn of the same chat)."""
        return self.model_copy(update={"messages": [*self.messages, *more]})

    def tool_names(self) -> list[str]:
        return [tool.name for tool in self.tools]
