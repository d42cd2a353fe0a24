"""A typed state-graph runtime with LangGraph's API: nodes, edges, Send, Command, interrupt, checkpoints.

A LangGraph program of the supported shapes runs with only its imports changed. Beyond LangGraph: node updates
are validated against the state schema, checkpoints store deltas (append-only lists grow linearly), errors name
the node, key or edge at fault, and a run stopped by ``recursion_limit`` is checkpointed and can continue.

>>> from typing import Annotated, TypedDict
>>> import operator
>>> from agentic_core.graph import StateGraph, START, END
>>> class State(TypedDict):
...     log: Annotated[list[str], operator.add]
>>> g = StateGraph(State)
>>> _ = g.add_node("plan", lambda s: {"log": ["plan"]})
>>> _ = g.add_node("act", lambda s: {"log": ["act"]})
>>> _ = g.add_edge(START, "plan").add_edge("plan", "act").add_edge("act", END)
>>> g.compile().invoke({"log": []})
{'log': ['plan', 'act']}
"""

from typing import TYPE_CHECKING, Any

from .checkpoint import BaseCheckpointSaver, InMemorySaver, MemorySaver, SqliteSaver
from .compiled import CompiledStateGraph
from .constants import END, START
from .context import get_config, get_store, get_stream_writer, interrupt
from .errors import (
    CheckpointError,
    EmptyInputError,
    GraphCompileError,
    GraphError,
    GraphInterrupt,
    GraphRecursionError,
    InvalidRouteError,
    InvalidUpdateError,
    NodeTimeoutError,
    StateTypeError,
)
from .graph import StateGraph
from .types import Command, Interrupt, PregelTask, RetryPolicy, Send, StateSnapshot, StreamMode

if TYPE_CHECKING:
    from .message import REMOVE_ALL_MESSAGES, MessagesState, add_messages

_MESSAGE_NAMES = frozenset({"REMOVE_ALL_MESSAGES", "MessagesState", "add_messages"})


def __getattr__(name: str) -> Any:
    """The chat-message names on first use: they bring in pydantic, which a graph without messages need not load."""
    if name in _MESSAGE_NAMES:
        from . import message

        return getattr(message, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "END",
    "REMOVE_ALL_MESSAGES",
    "START",
    "BaseCheckpointSaver",
    "CheckpointError",
    "Command",
    "CompiledStateGraph",
    "EmptyInputError",
    "GraphCompileError",
    "GraphError",
    "GraphInterrupt",
    "GraphRecursionError",
    "InMemorySaver",
    "Interrupt",
    "InvalidRouteError",
    "InvalidUpdateError",
    "MemorySaver",
    "MessagesState",
    "NodeTimeoutError",
    "PregelTask",
    "RetryPolicy",
    "Send",
    "SqliteSaver",
    "StateGraph",
    "StateSnapshot",
    "StateTypeError",
    "StreamMode",
    "add_messages",
    "get_config",
    "get_store",
    "get_stream_writer",
    "interrupt",
]
