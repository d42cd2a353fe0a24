"""Chat messages as pydantic models: what a tool-calling agent keeps in its ``messages`` state.

The classes carry the fields and ``type`` names of LangChain's messages, so a LangGraph agent runs with only its
imports changed; :func:`to_message` turns the shorthands LangGraph accepts (``("user", "hi")``, role dicts,
LangChain's own message objects, duck-typed) into these models without importing LangChain.

>>> ai = AIMessage("", tool_calls=[{"name": "wind", "args": {"lat": 1.0}, "id": "c1"}])
>>> ai.type, ai.tool_calls[0]["name"]
('ai', 'wind')
>>> to_message(("user", "hi"))
HumanMessage(content='hi', type='human', id=None, name=None, additional_kwargs={}, response_metadata={})
>>> ToolMessage("4.2", tool_call_id="c1").status
'success'
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Annotated, Any, Literal, NotRequired, TypeAlias

from pydantic import BaseModel, ConfigDict, Field, ValidationError
from typing_extensions import TypeAliasType, TypedDict

from .errors import InputError

Content: TypeAlias = str | list[str | dict[str, Any]]


class ToolCall(TypedDict):
    """One tool call an AI message asks for: the tool's name, its arguments and an id its answer refers to."""

    name: str
    args: dict[str, Any]
    id: str | None
    type: NotRequired[Literal["tool_call"]]


class BaseMessage(BaseModel):
    """Fields every message has. ``content`` may be given positionally, as in LangChain."""

    model_config = ConfigDict(extra="forbid", validate_assignment=False)

    content: Content
    type: str  # each kind of message fixes it: "human", "ai", "system", "tool", "remove"
    id: str | None = None
    name: str | None = None
    additional_kwargs: dict[str, Any] = Field(default_factory=dict)
    response_metadata: dict[str, Any] = Field(default_factory=dict)

    def __init__(self, content: Content | None = None, /, **data: Any) -> None:
        if content is not None:
            if "content" in data:
                raise TypeError(f"{type(self).__name__}: content given twice (positionally and by keyword)")
            data["content"] = content
        super().__init__(**data)

    @property
    def text(self) -> str:
        """The text of ``content``: the string itself, or the text parts of a list joined."""
        if isinstance(self.content, str):
            return self.content
        parts = [p if isinstance(p, str) else str(p.get("text", "")) for p in self.content]
        return "".join(p for p in parts if p)


class HumanMessage(BaseMessage):
    """What the user said."""

    type: Literal["human"] = "human"

    def __init__(self, content: Content | None = None, /, **data: Any) -> None:  # here too, for mypy's plugin
        super().__init__(content, **data)


class AIMessage(BaseMessage):
    """What the model said; ``tool_calls`` lists the tools it wants run before it answers."""

    type: Literal["ai"] = "ai"
    tool_calls: list[ToolCall] = Field(default_factory=list)

    def __init__(self, content: Content | None = None, /, **data: Any) -> None:  # here too, for mypy's plugin
        super().__init__(content, **data)


class SystemMessage(BaseMessage):
    """Instructions to the model."""

    type: Literal["system"] = "system"

    def __init__(self, content: Content | None = None, /, **data: Any) -> None:  # here too, for mypy's plugin
        super().__init__(content, **data)


class ToolMessage(BaseMessage):
    """A tool's answer to one tool call; ``status`` is ``"error"`` when the call failed or was refused."""

    type: Literal["tool"] = "tool"
    tool_call_id: str
    status: Literal["success", "error"] = "success"
    artifact: Any = None

    def __init__(self, content: Content | None = None, /, **data: Any) -> None:  # here too, for mypy's plugin
        super().__init__(content, **data)


class RemoveMessage(BaseMessage):
    """Written to a ``messages`` key, deletes the message with this id (``REMOVE_ALL_MESSAGES``: all of them)."""

    type: Literal["remove"] = "remove"
    content: Content = ""
    id: str  # required here: it names the message to delete

    def __init__(self, id: str | None = None, /, **data: Any) -> None:
        if id is not None:
            data["id"] = id
        super().__init__(**data)


AnyMessage = TypeAliasType(
    "AnyMessage",
    Annotated[HumanMessage | AIMessage | SystemMessage | ToolMessage | RemoveMessage, Field(discriminator="type")],
)
"""Any message, told apart by its ``type`` (a named alias, so errors say ``list[AnyMessage]``)."""

REMOVE_ALL_MESSAGES = "__remove_all__"

_ROLES: dict[str, type[BaseMessage]] = {
    "human": HumanMessage,
    "user": HumanMessage,
    "ai": AIMessage,
    "assistant": AIMessage,
    "system": SystemMessage,
    "developer": SystemMessage,
    "tool": ToolMessage,
    "remove": RemoveMessage,
}
_FIELDS = ("id", "name", "tool_call_id", "status", "artifact", "additional_kwargs", "response_metadata")


class MessageError(InputError):
    """A value that is not a message and cannot be made into one; the error says which value and why."""


def _role_class(role: Any, what: str) -> type[BaseMessage]:
    key = role.lower().removesuffix("messagechunk") if isinstance(role, str) else role
    cls = _ROLES.get(key) if isinstance(key, str) else None
    if cls is None:
        known = ", ".join(sorted(_ROLES))
        raise MessageError(f"{what} has role/type {role!r}; use one of {known}")
    return cls


def _tool_call(call: Any) -> Any:
    """A tool call in our shape; OpenAI's ``{"function": {"name", "arguments": "<json>"}}`` form is unpacked."""
    if isinstance(call, Mapping) and isinstance(call.get("function"), Mapping):
        fn = call["function"]
        args = fn.get("arguments") or {}
        if isinstance(args, str):
            try:
                args = json.loads(args)
            except json.JSONDecodeError as exc:
                raise MessageError(f"tool call {call.get('id')!r}: arguments are not JSON: {exc}") from None
        return {"name": fn.get("name"), "args": args, "id": call.get("id")}
    if isinstance(call, Mapping):
        return {"name": call.get("name"), "args": call.get("args", {}), "id": call.get("id")}
    return call  # let validation name what is wrong


def _build(cls: type[BaseMessage], fields: dict[str, Any], what: str) -> BaseMessage:
    if cls is AIMessage and fields.get("tool_calls"):
        fields["tool_calls"] = [_tool_call(c) for c in fields["tool_calls"]]
    try:
        return cls.model_validate(fields)
    except ValidationError as exc:
        problem = exc.errors()[0]
        where = ".".join(str(p) for p in problem.get("loc", ()))
        raise MessageError(f"{what}: {cls.__name__} field {where or '?'}: {problem.get('msg', '')}") from None


def to_message(value: Any, what: str = "message") -> BaseMessage:
    """``value`` as one of our messages: ours as is; a string as a HumanMessage; ``(role, content)``; a dict with
    ``role`` or ``type``; or any object with ``type`` and ``content`` attributes (LangChain's messages)."""
    if isinstance(value, BaseMessage):
        return value
    if isinstance(value, str):
        return HumanMessage(content=value)
    if isinstance(value, tuple | list) and len(value) == 2 and isinstance(value[0], str):
        return _build(_role_class(value[0], what), {"content": value[1]}, what)
    if isinstance(value, Mapping):
        fields = dict(value)
        role = fields.pop("role", None) or fields.pop("type", None)
        if role is None:
            raise MessageError(f"{what} is a dict without 'role' or 'type': {sorted(map(str, fields))}")
        fields.pop("type", None)
        return _build(_role_class(role, what), fields, what)
    kind, content = getattr(value, "type", None), getattr(value, "content", None)
    if isinstance(kind, str) and content is not None:
        cls = _role_class(kind, what)
        fields = {"content": content}
        fields.update({f: getattr(value, f) for f in _FIELDS if getattr(value, f, None) is not None})
        if cls is AIMessage:
            fields["tool_calls"] = list(getattr(value, "tool_calls", None) or [])
        if cls is RemoveMessage:
            fields.pop("content", None)
        fields = {k: v for k, v in fields.items() if k in cls.model_fields}
        return _build(cls, fields, what)
    raise MessageError(
        f"{what} is a {type(value).__name__}, not a message: give a message, a string, a (role, content) pair "
        f"or a dict with 'role' and 'content'"
    )


__all__ = [
    "REMOVE_ALL_MESSAGES",
    "AIMessage",
    "AnyMessage",
    "BaseMessage",
    "Content",
    "HumanMessage",
    "MessageError",
    "RemoveMessage",
    "SystemMessage",
    "ToolCall",
    "ToolMessage",
    "to_message",
]
