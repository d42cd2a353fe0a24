"""Compile-time checks and the Mermaid drawing."""

from typing import Literal, TypedDict

import pytest

from agentic_core.graph import END, START, GraphCompileError, GraphError, InvalidRouteError, StateGraph


class S(TypedDict, total=False):
    n: int


def noop(state: S) -> None:
    return None


def test_unknown_node_in_edge_is_named_with_a_suggestion() -> None:
    g = StateGraph(S)
    g.add_node("takeoff", noop)
    g.add_edge(START, "takeoff")
    g.add_edge("takeoff", "tkaeoff_2")
    with pytest.raises(GraphCompileError) as err:
        g.compile()
    assert "'tkaeoff_2'" in str(err.value) and "edge 'takeoff' -> 'tkaeoff_2'" in str(err.value)


def test_suggests_the_closest_name() -> None:
    g = StateGraph(S)
    g.add_node("survey", noop)
    g.add_edge(START, "survey")
    g.add_edge("survey", "survy")
    with pytest.raises(GraphCompileError, match="did you mean 'survey'"):
        g.compile()


def test_no_entry_point() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge("a", END)
    with pytest.raises(GraphCompileError, match=r"no entry point: add_edge\(START"):
        g.compile()


def test_node_with_no_path_to_end() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_node("b", noop)
    g.add_node("c", noop)
    g.add_edge(START, "a")
    g.add_edge("a", END)
    g.add_edge("a", "b")
    g.add_edge("b", "c")
    g.add_edge("c", "b")
    with pytest.raises(GraphCompileError) as err:
        g.compile()
    msg = str(err.value)
    assert "'b'" in msg and "'c'" in msg and "no path to END" in msg and "'a'" not in msg.split("(")[0]


def test_dead_end_node_is_refused_with_advice() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge(START, "a")
    with pytest.raises(GraphCompileError, match="'a' has no outgoing edge"):
        g.compile()


def test_command_node_with_declared_destinations_passes() -> None:
    g = StateGraph(S)
    g.add_node("a", noop, destinations=("b",))
    g.add_node("b", noop)
    g.add_edge(START, "a")
    g.add_edge("b", END)
    g.compile()


def test_router_annotation_outside_path_map_fails_at_compile_time() -> None:
    def route(state: S) -> Literal["a", "b"]:
        return "a"

    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge(START, "a")
    g.add_conditional_edges("a", route, {"a": END})
    with pytest.raises(GraphCompileError, match=r"\['b'\]"):
        g.compile()


def test_path_map_to_unknown_node() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge(START, "a")
    g.add_conditional_edges("a", lambda s: "x", {"x": "nowhere", "y": END})
    with pytest.raises(GraphCompileError, match=r"path_map.*'nowhere'"):
        g.compile()


def test_router_returning_outside_path_map_at_run_time() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge(START, "a")
    g.add_conditional_edges("a", lambda s: "elsewhere", {"done": END})
    with pytest.raises(InvalidRouteError) as err:
        g.compile().invoke({"n": 1})
    assert "'elsewhere'" in str(err.value) and "'done'" in str(err.value) and "from 'a'" in str(err.value)


def test_interrupt_before_unknown_node() -> None:
    g = StateGraph(S)
    g.add_node("a", noop)
    g.add_edge(START, "a")
    g.add_edge("a", END)
    with pytest.raises(GraphCompileError, match="interrupt_before/interrupt_after names unknown node 'land'"):
        g.compile(interrupt_before=["land"])


@pytest.mark.parametrize("name", [START, END, "a|b", "a:b"])
def test_reserved_and_malformed_node_names(name: str) -> None:
    with pytest.raises(GraphError):
        StateGraph(S).add_node(name, noop)


def test_duplicate_node() -> None:
    g = StateGraph(S).add_node("a", noop)
    with pytest.raises(GraphError, match="already in the graph"):
        g.add_node("a", noop)


def test_add_node_infers_name_and_add_sequence_chains() -> None:
    def first(state: S) -> dict[str, int]:
        return {"n": state["n"] + 1}

    def second(state: S) -> dict[str, int]:
        return {"n": state["n"] * 10}

    g = StateGraph(S).add_sequence([first, second])
    g.set_entry_point("first")
    g.set_finish_point("second")
    assert g.compile().invoke({"n": 1}) == {"n": 20}


def test_draw_mermaid_shows_nodes_edges_and_conditional_labels() -> None:
    def route(state: S) -> str:
        return "again"

    g = StateGraph(S)
    g.add_node("inc", noop)
    g.add_node("check", noop)
    g.add_edge(START, "inc")
    g.add_edge("inc", "check")
    g.add_conditional_edges("check", route, {"again": "inc", "stop": END})
    text = g.compile().get_graph().draw_mermaid()
    assert text.startswith("---\nconfig:\n  flowchart:\n    curve: linear\n---\ngraph TD;\n")
    assert "\t__start__ --> inc;" in text
    assert "\tinc --> check;" in text
    assert "\tcheck -. &nbsp;again&nbsp; .-> inc;" in text
    assert "\tcheck -. &nbsp;stop&nbsp; .-> __end__;" in text


def test_unsupported_langgraph_arguments_are_refused_not_ignored() -> None:
    with pytest.raises(GraphError, match=r"StateGraph\(\): input_schema not supported"):
        StateGraph(S, input_schema=S)
    with pytest.raises(GraphError, match=r"add_node\(\): cache_policy not supported"):
        StateGraph(S).add_node("a", noop, cache_policy=object())
    g = StateGraph(S).add_node("a", noop, metadata={"kind": "flight"})
    g.add_edge(START, "a").add_edge("a", END)
    with pytest.raises(GraphError, match=r"compile\(\): cache not supported"):
        g.compile(cache=object())
    with pytest.raises(GraphError, match=r"store must have the Store API \(missing get, put, search\)"):
        g.compile(store=object())
    app = g.compile()
    with pytest.raises(GraphError, match=r"invoke\(\): output_keys not supported"):
        app.invoke({"n": 1}, output_keys=["n"])
    with pytest.raises(GraphError, match=r"use stream\(\)"):
        app.invoke({"n": 1}, stream_mode="updates")
    assert app.invoke({"n": 1}, debug=False) == {"n": 1}
