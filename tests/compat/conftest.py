"""The ``api`` fixture: the graph API of one implementation, so each compat program runs on both.

Every program in this package is written the way a LangGraph user writes it; the only thing that changes
between the two runs is where ``StateGraph``, ``START``, ``END``, ``Send``, ``Command``, ``interrupt`` and
``InMemorySaver`` come from. The langgraph run is skipped when langgraph is not installed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal

import pytest


@dataclass(frozen=True)
class GraphAPI:
    """The names a LangGraph program imports, taken from one implementation."""

    name: str
    StateGraph: Any
    START: Literal["__start__"]
    END: Literal["__end__"]
    Send: Any
    Command: Any
    interrupt: Any
    InMemorySaver: Any
    GraphRecursionError: type[Exception]

    def __repr__(self) -> str:
        return f"GraphAPI({self.name})"


def agentic_api() -> GraphAPI:
    from agentic_core.graph import (
        END,
        START,
        Command,
        GraphRecursionError,
        InMemorySaver,
        Send,
        StateGraph,
        interrupt,
    )

    return GraphAPI(
        name="agentic_core",
        StateGraph=StateGraph,
        START=START,
        END=END,
        Send=Send,
        Command=Command,
        interrupt=interrupt,
        InMemorySaver=InMemorySaver,
        GraphRecursionError=GraphRecursionError,
    )


def langgraph_api() -> GraphAPI:
    graph = pytest.importorskip("langgraph.graph")
    types = pytest.importorskip("langgraph.types")
    memory = pytest.importorskip("langgraph.checkpoint.memory")
    errors = pytest.importorskip("langgraph.errors")
    return GraphAPI(
        name="langgraph",
        StateGraph=graph.StateGraph,
        START=graph.START,
        END=graph.END,
        Send=types.Send,
        Command=types.Command,
        interrupt=types.interrupt,
        InMemorySaver=memory.InMemorySaver,
        GraphRecursionError=errors.GraphRecursionError,
    )


@pytest.fixture(params=["agentic_core", "langgraph"])
def api(request: pytest.FixtureRequest) -> GraphAPI:
    """One implementation of the graph API; every test using it runs once per implementation."""
    return agentic_api() if request.param == "agentic_core" else langgraph_api()


@dataclass(frozen=True)
class AgentAPI:
    """What a LangGraph tool-calling agent imports: graph, messages, ToolNode, tools_condition and MemorySaver."""

    name: str
    StateGraph: Any
    START: Literal["__start__"]
    END: Literal["__end__"]
    MessagesState: Any
    add_messages: Any
    MemorySaver: Any
    ToolNode: Any
    tools_condition: Any
    HumanMessage: Any
    AIMessage: Any
    ToolMessage: Any
    SystemMessage: Any
    RemoveMessage: Any

    def __repr__(self) -> str:
        return f"AgentAPI({self.name})"


def agentic_agent_api() -> AgentAPI:
    from agentic_core.contracts.messages import AIMessage, HumanMessage, RemoveMessage, SystemMessage, ToolMessage
    from agentic_core.graph import END, START, MessagesState, StateGraph, add_messages
    from agentic_core.graph.checkpoint.memory import MemorySaver
    from agentic_core.prebuilt import ToolNode, tools_condition

    return AgentAPI(
        "agentic_core", StateGraph, START, END, MessagesState, add_messages, MemorySaver, ToolNode, tools_condition,
        HumanMessage, AIMessage, ToolMessage, SystemMessage, RemoveMessage,
    )  # fmt: skip


def langgraph_agent_api() -> AgentAPI:
    graph = pytest.importorskip("langgraph.graph")
    memory = pytest.importorskip("langgraph.checkpoint.memory")
    prebuilt = pytest.importorskip("langgraph.prebuilt")
    messages = pytest.importorskip("langchain_core.messages")
    return AgentAPI(
        "langgraph", graph.StateGraph, graph.START, graph.END, graph.MessagesState, graph.add_messages,
        memory.MemorySaver, prebuilt.ToolNode, prebuilt.tools_condition, messages.HumanMessage,
        messages.AIMessage, messages.ToolMessage, messages.SystemMessage, messages.RemoveMessage,
    )  # fmt: skip


@pytest.fixture(params=["agentic_core", "langgraph"])
def agent_api(request: pytest.FixtureRequest) -> AgentAPI:
    """The agent-building names of one implementation; every test using it runs once per implementation."""
    return agentic_agent_api() if request.param == "agentic_core" else langgraph_agent_api()
