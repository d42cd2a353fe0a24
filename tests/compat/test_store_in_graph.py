"""A graph compiled with ``store=...`` hands it to the nodes that ask, as LangGraph does: a ``store`` parameter
(keyword-only or not) and ``get_store()``; a subgraph uses its parent's. Run on both runtimes, with both stores."""

from __future__ import annotations

import operator
from typing import Annotated, Any, TypedDict

import pytest

from .conftest import GraphAPI


class S(TypedDict):
    user: str
    notes: Annotated[list[str], operator.add]


def get_store_of(api: GraphAPI) -> Any:
    if api.name == "langgraph":
        return pytest.importorskip("langgraph.config").get_store
    from agentic_core.graph import get_store

    return get_store


@pytest.fixture(params=["ours", "inmemory"])
def store(request: pytest.FixtureRequest) -> Any:
    if request.param == "inmemory":
        return pytest.importorskip("langgraph.store.memory").InMemoryStore()
    from agentic_core.memory import SqliteStore

    return SqliteStore()


def test_nodes_read_and_write_the_store_across_threads(api: GraphAPI, store: Any) -> None:
    get_store = get_store_of(api)

    def remember(state: S, *, store):
        store.put(("notes", state["user"]), "last", {"text": f"seen {state['user']}"})
        return {"notes": ["wrote"]}

    def recall(state: S):
        found = get_store().search(("notes",))
        return {"notes": [item.value["text"] for item in found]}

    builder = api.StateGraph(S)
    builder.add_node("remember", remember)
    builder.add_node("recall", recall)
    builder.add_edge(api.START, "remember")
    builder.add_edge("remember", "recall")
    builder.add_edge("recall", api.END)
    graph = builder.compile(checkpointer=api.InMemorySaver(), store=store)
    first = graph.invoke({"user": "amal", "notes": []}, {"configurable": {"thread_id": "1"}})
    second = graph.invoke({"user": "omar", "notes": []}, {"configurable": {"thread_id": "2"}})
    assert first["notes"] == ["wrote", "seen amal"]
    assert sorted(second["notes"][1:]) == ["seen amal", "seen omar"]  # another thread sees the first's memory
    assert store.get(("notes", "omar"), "last").value == {"text": "seen omar"}


def test_a_node_without_a_store_parameter_runs_as_before(api: GraphAPI, store: Any) -> None:
    def plain(state: S):
        return {"notes": ["plain"]}

    builder = api.StateGraph(S)
    builder.add_node("plain", plain)
    builder.add_edge(api.START, "plain")
    builder.add_edge("plain", api.END)
    assert builder.compile(store=store).invoke({"user": "x", "notes": []})["notes"] == ["plain"]


def test_a_subgraph_uses_its_parents_store(api: GraphAPI, store: Any) -> None:
    def inner(state: S, store):
        store.put(("sub",), state["user"], {"from": "subgraph"})
        return {"notes": ["inner"]}

    sub = api.StateGraph(S)
    sub.add_node("inner", inner)
    sub.add_edge(api.START, "inner")
    sub.add_edge("inner", api.END)
    builder = api.StateGraph(S)
    builder.add_node("sub", sub.compile())
    builder.add_edge(api.START, "sub")
    builder.add_edge("sub", api.END)
    builder.compile(store=store).invoke({"user": "zaid", "notes": []})
    assert store.get(("sub",), "zaid").value == {"from": "subgraph"}


def test_without_a_store_a_node_asking_for_one_gets_none(api: GraphAPI) -> None:
    seen: list[Any] = []

    def node(state: S, *, store=None):
        seen.append(store)
        return {"notes": ["ok"]}

    builder = api.StateGraph(S)
    builder.add_node("node", node)
    builder.add_edge(api.START, "node")
    builder.add_edge("node", api.END)
    builder.compile().invoke({"user": "x", "notes": []})
    assert seen == [None]
