"""A counter loop: one node increments, a conditional edge sends it round again or to END."""

import asyncio
import operator
import re
from typing import Annotated, Literal, TypedDict

import pytest

from .conftest import GraphAPI


class CounterState(TypedDict):
    count: int
    seen: Annotated[list[int], operator.add]


def build_counter(api: GraphAPI, *, stop_at: int = 3, checkpointer=None):
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def increment(state: CounterState):
        return {"count": state["count"] + 1, "seen": [state["count"]]}

    def should_continue(state: CounterState) -> Literal["inc", "__end__"]:
        if state["count"] < stop_at:
            return "inc"
        return END

    builder = StateGraph(CounterState)
    builder.add_node("inc", increment)
    builder.add_edge(START, "inc")
    builder.add_conditional_edges("inc", should_continue)
    return builder.compile(checkpointer=checkpointer)


def build_counter_with_path_map(api: GraphAPI, *, stop_at: int = 2):
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def increment(state: CounterState):
        return {"count": state["count"] + 1, "seen": [state["count"]]}

    def decide(state: CounterState) -> str:
        return "again" if state["count"] < stop_at else "done"

    builder = StateGraph(CounterState)
    builder.add_node("inc", increment)
    builder.add_edge(START, "inc")
    builder.add_conditional_edges("inc", decide, {"again": "inc", "done": END})
    return builder.compile()


def test_loops_until_the_router_returns_end(api: GraphAPI) -> None:
    graph = build_counter(api)
    assert graph.invoke({"count": 0, "seen": []}) == {"count": 3, "seen": [0, 1, 2]}


def test_node_runs_once_before_the_router_is_asked(api: GraphAPI) -> None:
    graph = build_counter(api)
    assert graph.invoke({"count": 10, "seen": []}) == {"count": 11, "seen": [10]}


def test_path_map_translates_router_keys(api: GraphAPI) -> None:
    graph = build_counter_with_path_map(api)
    assert graph.invoke({"count": 0, "seen": [-1]}) == {"count": 2, "seen": [-1, 0, 1]}


def test_stream_updates_is_one_chunk_per_node_run(api: GraphAPI) -> None:
    graph = build_counter(api)
    chunks = list(graph.stream({"count": 0, "seen": []}, stream_mode="updates"))
    assert chunks == [
        {"inc": {"count": 1, "seen": [0]}},
        {"inc": {"count": 2, "seen": [1]}},
        {"inc": {"count": 3, "seen": [2]}},
    ]


def test_stream_values_starts_with_the_input(api: GraphAPI) -> None:
    graph = build_counter(api, stop_at=2)
    chunks = list(graph.stream({"count": 0, "seen": []}, stream_mode="values"))
    assert chunks == [
        {"count": 0, "seen": []},
        {"count": 1, "seen": [0]},
        {"count": 2, "seen": [0, 1]},
    ]


def test_stream_values_shows_an_unwritten_reducer_key_as_empty(api: GraphAPI) -> None:
    # The input leaves out `seen`: LangGraph's list reducer channel starts as [] and is part of the state.
    graph = build_counter(api, stop_at=1)
    chunks = list(graph.stream({"count": 0}, stream_mode="values"))
    assert chunks == [{"count": 0, "seen": []}, {"count": 1, "seen": [0]}]


def test_stream_with_several_modes_pairs_mode_and_chunk(api: GraphAPI) -> None:
    graph = build_counter(api, stop_at=1)
    chunks = list(graph.stream({"count": 0, "seen": []}, stream_mode=["updates", "values"]))
    assert chunks == [
        ("values", {"count": 0, "seen": []}),
        ("updates", {"inc": {"count": 1, "seen": [0]}}),
        ("values", {"count": 1, "seen": [0]}),
    ]


def test_recursion_limit_counts_supersteps(api: GraphAPI) -> None:
    # Three runs of "inc" fit in recursion_limit=4 but not in recursion_limit=3 (LangGraph's boundary).
    graph = build_counter(api)
    assert graph.invoke({"count": 0, "seen": []}, {"recursion_limit": 4}) == {
        "count": 3,
        "seen": [0, 1, 2],
    }
    with pytest.raises(api.GraphRecursionError):
        graph.invoke({"count": 0, "seen": []}, {"recursion_limit": 3})


def test_recursion_error_is_a_recursion_error(api: GraphAPI) -> None:
    graph = build_counter(api, stop_at=100)
    with pytest.raises(RecursionError):
        graph.invoke({"count": 0, "seen": []}, {"recursion_limit": 10})


def test_ainvoke_and_astream(api: GraphAPI) -> None:
    graph = build_counter(api)

    async def main():
        final = await graph.ainvoke({"count": 1, "seen": []})
        updates = [chunk async for chunk in graph.astream({"count": 1, "seen": []}, stream_mode="updates")]
        return final, updates

    final, updates = asyncio.run(main())
    assert final == {"count": 3, "seen": [1, 2]}
    assert updates == [{"inc": {"count": 2, "seen": [1]}}, {"inc": {"count": 3, "seen": [2]}}]


def test_a_thread_keeps_its_state_between_invocations(api: GraphAPI) -> None:
    graph = build_counter(api, checkpointer=api.InMemorySaver())
    config = {"configurable": {"thread_id": "counter-1"}}
    assert graph.invoke({"count": 0, "seen": []}, config) == {"count": 3, "seen": [0, 1, 2]}
    # A second input on the same thread overwrites `count` and appends to `seen`.
    assert graph.invoke({"count": 1}, config) == {"count": 3, "seen": [0, 1, 2, 1, 2]}
    snapshot = graph.get_state(config)
    assert snapshot.values == {"count": 3, "seen": [0, 1, 2, 1, 2]}
    assert snapshot.next == ()
    # Another thread starts from nothing.
    other = {"configurable": {"thread_id": "counter-2"}}
    assert graph.invoke({"count": 2, "seen": []}, other) == {"count": 3, "seen": [2]}


def test_state_history_has_one_checkpoint_per_superstep(api: GraphAPI) -> None:
    graph = build_counter(api, stop_at=2, checkpointer=api.InMemorySaver())
    config = {"configurable": {"thread_id": "history"}}
    graph.invoke({"count": 0, "seen": []}, config)
    history = list(graph.get_state_history(config))
    # Newest first: two loop steps, the step that took the input from START, and the input itself.
    assert [s.values for s in history] == [
        {"count": 2, "seen": [0, 1]},
        {"count": 1, "seen": [0]},
        {"count": 0, "seen": []},
        {"seen": []},
    ]
    assert [s.next for s in history] == [(), ("inc",), ("inc",), ("__start__",)]
    assert [(s.metadata["source"], s.metadata["step"]) for s in history] == [
        ("loop", 2),
        ("loop", 1),
        ("loop", 0),
        ("input", -1),
    ]
    # Each checkpoint's parent is the one before it.
    ids = [s.config["configurable"]["checkpoint_id"] for s in history]
    parents = [s.parent_config["configurable"]["checkpoint_id"] if s.parent_config else None for s in history]
    assert parents == [*ids[1:], None]


def _mermaid_structure(text: str) -> tuple[set[str], set[tuple[str, str, bool]]]:
    """Node ids and (source, target, conditional) edges of a Mermaid flowchart, ignoring layout and order."""
    nodes = set(re.findall(r"^\s*([\w-]+)\(", text, flags=re.MULTILINE))
    edges = {
        (a, b, arrow.startswith("-."))
        for a, arrow, b in re.findall(r"^\s*([\w-]+) (-->|-\.->|-\. .*? \.->) ([\w-]+);", text, re.MULTILINE)
    }
    return nodes, edges


def test_draw_mermaid_shows_the_loop(api: GraphAPI) -> None:
    text = build_counter(api).get_graph().draw_mermaid()
    nodes, edges = _mermaid_structure(text)
    assert nodes == {"__start__", "inc", "__end__"}
    assert edges == {("__start__", "inc", False), ("inc", "inc", True), ("inc", "__end__", True)}


def test_replay_and_fork_from_an_earlier_checkpoint(api: GraphAPI) -> None:
    graph = build_counter(api, stop_at=3, checkpointer=api.InMemorySaver())
    config = {"configurable": {"thread_id": "time-travel"}}
    graph.invoke({"count": 0, "seen": []}, config)
    earlier = next(s for s in graph.get_state_history(config) if s.values.get("count") == 1)
    assert earlier.next == ("inc",)

    # Replaying from that checkpoint runs the remaining loop again.
    assert graph.invoke(None, earlier.config) == {"count": 3, "seen": [0, 1, 2]}

    # Forking: edit the old checkpoint, then continue from the edited copy.
    forked = graph.update_state(earlier.config, {"count": 2})
    assert graph.get_state(forked).values == {"count": 2, "seen": [0]}
    assert graph.get_state(forked).next == ("inc",)
    assert graph.invoke(None, forked) == {"count": 3, "seen": [0, 2]}
    assert graph.get_state(config).values == {"count": 3, "seen": [0, 2]}
