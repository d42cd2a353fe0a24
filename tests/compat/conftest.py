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
