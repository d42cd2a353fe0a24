"""Route annotations are read even when they cannot be resolved (``from __future__ import annotations`` with a
state class defined inside a function), by parsing their text."""

from __future__ import annotations

from typing import Literal, TypedDict

from agentic_core.graph import END, START, Command, StateGraph


def test_command_literal_annotation_of_a_local_state_class_is_read() -> None:
    class Local(TypedDict):
        n: int

    def bump(state: Local) -> Command[Literal["double", "__end__"]]:
        return Command(update={"n": state["n"] + 1}, goto="double")

    def double(state: Local) -> dict[str, int]:
        return {"n": state["n"] * 2}

    g = StateGraph(Local)
    g.add_node("bump", bump)
    g.add_node("double", double)
    g.add_edge(START, "bump")
    g.add_edge("double", END)
    assert g.nodes["bump"].destinations == ("double", "__end__")
    assert g.compile().invoke({"n": 9}) == {"n": 20}


def test_router_literal_annotation_of_a_local_state_class_is_read() -> None:
    class Local(TypedDict):
        n: int

    def route(state: Local) -> Literal["again", "__end__"]:
        return "again" if state["n"] < 3 else "__end__"

    g = StateGraph(Local)
    g.add_node("again", lambda s: {"n": s["n"] + 1})
    g.add_edge(START, "again")
    g.add_conditional_edges("again", route)
    assert g.compile().invoke({"n": 0}) == {"n": 3}
