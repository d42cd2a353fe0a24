"""Supersteps, joins, Send, Command, streaming and async execution."""

import asyncio
import operator
import threading
from typing import Annotated, Any, Literal, TypedDict

import pytest

from agentic_core.graph import (
    END,
    START,
    Command,
    GraphError,
    InvalidRouteError,
    Send,
    StateGraph,
    get_stream_writer,
)


class Log(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    n: int


def writes(name: str) -> Any:
    return lambda state: {"log": [name]}


def test_nodes_of_one_superstep_run_concurrently() -> None:
    barrier = threading.Barrier(2, timeout=5)

    def meet(name: str) -> Any:
        def node(state: Log) -> dict[str, list[str]]:
            barrier.wait()  # raises BrokenBarrierError unless both run at the same time
            return {"log": [name]}

        return node

    g = StateGraph(Log)
    g.add_node("a", meet("a"))
    g.add_node("b", meet("b"))
    g.add_edge(START, "a")
    g.add_edge(START, "b")
    g.add_edge("a", END)
    g.add_edge("b", END)
    assert g.compile().invoke({"log": []}) == {"log": ["a", "b"]}


def test_join_waits_for_all_sources_even_across_supersteps() -> None:
    g = StateGraph(Log)
    for name in ("a", "b1", "b2", "c"):
        g.add_node(name, writes(name))
    g.add_edge(START, "a")
    g.add_edge(START, "b1")
    g.add_edge("b1", "b2")
    g.add_edge(["a", "b2"], "c")
    g.add_edge("c", END)
    out = g.compile().stream({"log": []}, stream_mode="updates")
    order = [next(iter(chunk)) for chunk in out]
    assert order == ["a", "b1", "b2", "c"]


def test_plain_edges_from_two_nodes_trigger_the_target_once_per_step() -> None:
    g = StateGraph(Log)
    for name in ("a", "b", "c"):
        g.add_node(name, writes(name))
    g.add_edge(START, "a")
    g.add_edge(START, "b")
    g.add_edge("a", "c")
    g.add_edge("b", "c")
    g.add_edge("c", END)
    assert g.compile().invoke({"log": []})["log"] == ["a", "b", "c"]


class MapState(TypedDict, total=False):
    items: list[int]
    results: Annotated[list[int], operator.add]
    best: int


def test_send_fans_out_and_results_keep_send_order() -> None:
    def square(arg: dict[str, int]) -> dict[str, list[int]]:
        return {"results": [arg["x"] ** 2]}

    g = StateGraph(MapState)
    g.add_node("square", square)
    g.add_node("pick", lambda s: {"best": max(s["results"])})
    g.add_conditional_edges(START, lambda s: [Send("square", {"x": i}) for i in s["items"]], ["square"])
    g.add_edge("square", "pick")
    g.add_edge("pick", END)
    assert g.compile().invoke({"items": [3, 1, 2]}) == {"items": [3, 1, 2], "results": [9, 1, 4], "best": 9}


def test_send_to_unknown_node_is_named() -> None:
    g = StateGraph(MapState)
    g.add_node("square", lambda a: None)
    g.add_conditional_edges(START, lambda s: [Send("sqaure", {})], ["square"])
    g.add_edge("square", END)
    with pytest.raises(InvalidRouteError, match="'sqaure'"):
        g.compile().invoke({"items": []})


def test_command_updates_and_routes() -> None:
    def decide(state: Log) -> Command[Literal["left", "right"]]:
        return Command(update={"n": 1}, goto="right")

    g = StateGraph(Log)
    g.add_node("decide", decide)
    g.add_node("left", writes("left"))
    g.add_node("right", writes("right"))
    g.add_edge(START, "decide")
    g.add_edge("left", END)
    g.add_edge("right", END)
    assert g.compile().invoke({"log": []}) == {"log": ["right"], "n": 1}


def test_command_goto_unknown_node_is_named() -> None:
    g = StateGraph(Log)
    g.add_node("decide", lambda s: Command(goto="nowhere"), destinations=[END])
    g.add_edge(START, "decide")
    with pytest.raises(InvalidRouteError, match="'decide' routed to unknown node 'nowhere'"):
        g.compile().invoke({"log": []})


def line_graph() -> Any:
    g = StateGraph(Log)
    g.add_node("a", writes("a"))
    g.add_node("b", writes("b"))
    g.add_edge(START, "a")
    g.add_edge("a", "b")
    g.add_edge("b", END)
    return g.compile()


def test_stream_values_starts_with_the_input() -> None:
    chunks = list(line_graph().stream({"log": ["in"]}))
    assert chunks == [{"log": ["in"]}, {"log": ["in", "a"]}, {"log": ["in", "a", "b"]}]


def test_stream_updates_and_multiple_modes() -> None:
    app = line_graph()
    assert list(app.stream({"log": []}, stream_mode="updates")) == [{"a": {"log": ["a"]}}, {"b": {"log": ["b"]}}]
    pairs = list(app.stream({"log": []}, stream_mode=["updates", "values"]))
    assert [m for m, _ in pairs] == ["values", "updates", "values", "updates", "values"]


def test_stream_debug_reports_tasks_and_results() -> None:
    events = list(line_graph().stream({"log": []}, stream_mode="debug"))
    kinds = [(e["type"], e["payload"].get("name")) for e in events]
    assert kinds == [("task", "a"), ("task_result", "a"), ("task", "b"), ("task_result", "b")]
    assert events[1]["payload"]["result"] == [("log", ["a"])]


def test_stream_custom_chunks_arrive_while_the_node_runs() -> None:
    release = threading.Event()
    seen_before_release: list[Any] = []

    def talker(state: Log) -> dict[str, list[str]]:
        write = get_stream_writer()
        write({"progress": 0.5})
        assert release.wait(5), "the caller never saw the custom chunk while the node was running"
        write({"progress": 1.0})
        return {"log": ["talked"]}

    g = StateGraph(Log)
    g.add_node("talker", talker)
    g.add_edge(START, "talker")
    g.add_edge("talker", END)
    chunks = []
    for mode, chunk in g.compile().stream({"log": []}, stream_mode=["custom", "updates"]):
        if chunk == {"progress": 0.5}:
            seen_before_release.append(chunk)
            release.set()
        chunks.append((mode, chunk))
    assert seen_before_release == [{"progress": 0.5}]
    assert chunks == [
        ("custom", {"progress": 0.5}),
        ("custom", {"progress": 1.0}),
        ("updates", {"talker": {"log": ["talked"]}}),
    ]


def test_node_may_take_config_and_writer_parameters() -> None:
    def node(state: Log, config: dict[str, Any], writer: Any) -> dict[str, Any]:
        writer(config["configurable"]["mission"])
        return {"log": [config["configurable"]["mission"]]}

    g = StateGraph(Log)
    g.add_node("node", node)
    g.add_edge(START, "node")
    g.add_edge("node", END)
    cfg = {"configurable": {"mission": "sar-1"}}
    assert list(g.compile().stream({"log": []}, cfg, stream_mode="custom")) == ["sar-1"]


def test_unknown_stream_mode() -> None:
    with pytest.raises(GraphError, match="unknown stream_mode 'tokens'"):
        list(line_graph().stream({"log": []}, stream_mode="tokens"))


def test_node_error_keeps_its_type_and_names_the_node() -> None:
    def broken(state: Log) -> None:
        raise ZeroDivisionError("bad maths")

    g = StateGraph(Log)
    g.add_node("broken", broken)
    g.add_edge(START, "broken")
    g.add_edge("broken", END)
    with pytest.raises(ZeroDivisionError) as err:
        g.compile().invoke({"log": []})
    assert any("in node 'broken'" in note for note in err.value.__notes__)


def async_graph() -> Any:
    both_started = asyncio.Event()
    started: list[str] = []

    def make(name: str) -> Any:
        async def node(state: Log) -> dict[str, list[str]]:
            started.append(name)
            if len(started) == 2:
                both_started.set()
            await asyncio.wait_for(both_started.wait(), 5)
            return {"log": [name]}

        return node

    g = StateGraph(Log)
    g.add_node("a", make("a"))
    g.add_node("b", make("b"))
    g.add_node("c", writes("c"))  # a sync node in an async run
    g.add_edge(START, "a")
    g.add_edge(START, "b")
    g.add_edge(["a", "b"], "c")
    g.add_edge("c", END)
    return g.compile()


def test_ainvoke_runs_async_nodes_concurrently_and_sync_nodes_too() -> None:
    assert asyncio.run(async_graph().ainvoke({"log": []})) == {"log": ["a", "b", "c"]}


def test_astream_updates() -> None:
    async def collect() -> list[Any]:
        return [c async for c in async_graph().astream({"log": []}, stream_mode="updates")]

    assert asyncio.run(collect()) == [{"a": {"log": ["a"]}}, {"b": {"log": ["b"]}}, {"c": {"log": ["c"]}}]


def test_async_custom_stream() -> None:
    async def talker(state: Log) -> None:
        get_stream_writer()("hello")

    g = StateGraph(Log)
    g.add_node("talker", talker)
    g.add_edge(START, "talker")
    g.add_edge("talker", END)

    async def collect() -> list[Any]:
        return [c async for c in g.compile().astream({"log": []}, stream_mode="custom")]

    assert asyncio.run(collect()) == ["hello"]


def test_sync_invoke_runs_async_nodes() -> None:
    async def node(state: Log) -> dict[str, list[str]]:
        await asyncio.sleep(0)
        return {"log": ["async"]}

    g = StateGraph(Log)
    g.add_node("node", node)
    g.add_edge(START, "node")
    g.add_edge("node", END)
    assert g.compile().invoke({"log": []}) == {"log": ["async"]}


class Outer(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    mission: str


class Inner(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    private: int


def test_subgraph_as_node_shares_keys_and_drops_its_private_ones() -> None:
    sub = StateGraph(Inner)
    sub.add_node("inner", lambda s: {"log": ["inner"], "private": 1})
    sub.add_edge(START, "inner")
    sub.add_edge("inner", END)
    g = StateGraph(Outer)
    g.add_node("before", writes("before"))
    g.add_node("sub", sub.compile())
    g.add_edge(START, "before")
    g.add_edge("before", "sub")
    g.add_edge("sub", END)
    out = g.compile().invoke({"log": [], "mission": "m"})
    # the subgraph returns its whole log (which it received from the parent); the reducer appends it
    assert out == {"log": ["before", "before", "inner"], "mission": "m"}
