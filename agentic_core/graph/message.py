"""The ``messages`` state of a chat agent: the ``add_messages`` reducer and ``MessagesState``, as LangGraph has them.

>>> from agentic_core.contracts.messages import AIMessage, HumanMessage, RemoveMessage
>>> history = add_messages([HumanMessage("hi", id="1")], AIMessage("hello", id="2"))
>>> [m.content for m in history]
['hi', 'hello']
>>> [m.content for m in add_messages(history, AIMessage("hello again", id="2"))]  # same id: replaced
['hi', 'hello again']
>>> [m.id for m in add_messages(history, RemoveMessage("1"))]
['2']
>>> add_messages([], ("user", "a question"))[0].type
'human'
"""

from __future__ import annotations

import uuid
from typing import Annotated, Any

from typing_extensions import TypedDict

from ..contracts.messages import REMOVE_ALL_MESSAGES, AnyMessage, BaseMessage, MessageError, RemoveMessage, to_message


def _as_messages(value: Any, side: str) -> list[BaseMessage]:
    items = value if isinstance(value, list) else [value]
    out: list[BaseMessage] = []
    for index, item in enumerate(items):
        message = to_message(item, f"{side}[{index}]")
        if message.id is None:  # a copy with an id: the caller's message is left as it was
            message = message.model_copy(update={"id": str(uuid.uuid4())})
        out.append(message)
    return out


def add_messages(left: Any, right: Any) -> list[BaseMessage]:
    """Merge ``right`` into ``left``: new messages are appended, a message whose id is already there replaces it,
    ``RemoveMessage(id)`` deletes one and ``RemoveMessage(REMOVE_ALL_MESSAGES)`` all before it. Either side may be
    one message or a list; shorthands are turned into messages and messages without an id get one. The inputs
    are not changed: the result is a new list.

    Raises :class:`~agentic_core.contracts.messages.MessageError` (a ``ValueError``) for a value that is not a
    message, and for a ``RemoveMessage`` whose id is not in the list.
    """
    base = _as_messages(left, "messages")
    new = _as_messages(right, "update")
    for index in range(len(new) - 1, -1, -1):
        if isinstance(new[index], RemoveMessage) and new[index].id == REMOVE_ALL_MESSAGES:
            return new[index + 1 :]
    merged: list[BaseMessage] = list(base)
    position = {m.id: i for i, m in enumerate(merged)}
    removed: set[str] = set()
    for message in new:
        key = message.id
        assert key is not None  # _as_messages gave every message an id
        at = position.get(key)
        if isinstance(message, RemoveMessage):
            if at is None:
                raise MessageError(
                    f"RemoveMessage({key!r}): no message with that id in the list "
                    f"({len(merged)} messages); nothing was removed"
                )
            removed.add(key)
        elif at is None:
            position[key] = len(merged)
            merged.append(message)
        else:
            removed.discard(key)
            merged[at] = message
    if removed:
        merged = [m for m in merged if m.id not in removed]
    return merged


class MessagesState(TypedDict):
    """A state with one key, ``messages``, merged by :func:`add_messages`; subclass it to add keys."""

    messages: Annotated[list[AnyMessage], add_messages]


__all__ = ["REMOVE_ALL_MESSAGES", "MessagesState", "add_messages"]
