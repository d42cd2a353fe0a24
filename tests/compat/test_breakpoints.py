"""Static breakpoints (interrupt_before / interrupt_after), editing the paused state, continuing with None."""

import operator
from typing import Annotated, TypedDict

from .conftest import GraphAPI


class SortieState(TypedDict):
    altitude_m: int
    route: list[str]
    events: Annotated[list[str], operator.add]


def build_sortie(api: GraphAPI, *, interrupt_before=None, interrupt_after=None):
    StateGraph, START, END, InMemorySaver = api.StateGraph, api.START, api.END, api.InMemorySaver

    def plan_route(state: SortieState):
        return {"route": ["wp1", "wp2"], "events": ["planned"]}

    def takeoff(state: SortieState):
        return {"events": [f"climbed to {state['altitude_m']} m"]}

    def survey(state: SortieState):
        return {"events": [f"surveyed {'+'.join(state['route'])}"]}

    def land(state: SortieState):
        return {"altitude_m": 0, "events": ["landed"]}

    builder = StateGraph(SortieState)
    builder.add_node("plan_route", plan_route)
    builder.add_node("takeoff", takeoff)
    builder.add_node("survey", survey)
    builder.add_node("land", land)
    builder.add_edge(START, "plan_route")
    builder.add_edge("plan_route", "takeoff")
    builder.add_edge("takeoff", "survey")
    builder.add_edge("survey", "land")
    builder.add_edge("land", END)
    return builder.compile(
        checkpointer=InMemorySaver(), interrupt_before=interrupt_before, interrupt_after=interrupt_after
    )


START_INPUT = {"altitude_m": 40, "events": []}
PLANNED = {"altitude_m": 40, "route": ["wp1", "wp2"], "events": ["planned"]}


def test_interrupt_before_stops_ahead_of_the_node(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["takeoff"])
    config = {"configurable": {"thread_id": "before"}}
    assert graph.invoke(START_INPUT, config) == PLANNED
    snapshot = graph.get_state(config)
    assert snapshot.next == ("takeoff",)
    assert snapshot.values == PLANNED
    assert snapshot.interrupts == ()


def test_invoke_none_continues_from_the_breakpoint(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["takeoff"])
    config = {"configurable": {"thread_id": "continue"}}
    graph.invoke(START_INPUT, config)
    assert graph.invoke(None, config) == {
        "altitude_m": 0,
        "route": ["wp1", "wp2"],
        "events": ["planned", "climbed to 40 m", "surveyed wp1+wp2", "landed"],
    }
    assert graph.get_state(config).next == ()


def test_update_state_at_the_breakpoint_is_seen_by_the_next_node(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["takeoff"])
    config = {"configurable": {"thread_id": "edit"}}
    graph.invoke(START_INPUT, config)
    graph.update_state(config, {"altitude_m": 60, "route": ["wp3"]})
    edited = graph.get_state(config)
    assert edited.values == {"altitude_m": 60, "route": ["wp3"], "events": ["planned"]}
    assert edited.next == ("takeoff",)
    assert graph.invoke(None, config)["events"] == ["planned", "climbed to 60 m", "surveyed wp3", "landed"]


def test_update_state_as_node_skips_that_node(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["takeoff"])
    config = {"configurable": {"thread_id": "as-node"}}
    graph.invoke(START_INPUT, config)
    graph.update_state(config, {"events": ["hand launched"]}, as_node="takeoff")
    assert graph.get_state(config).next == ("survey",)
    assert graph.invoke(None, config)["events"] == ["planned", "hand launched", "surveyed wp1+wp2", "landed"]


def test_interrupt_after_stops_behind_the_node(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_after=["survey"])
    config = {"configurable": {"thread_id": "after"}}
    paused = graph.invoke(START_INPUT, config)
    assert paused == {
        "altitude_m": 40,
        "route": ["wp1", "wp2"],
        "events": ["planned", "climbed to 40 m", "surveyed wp1+wp2"],
    }
    assert graph.get_state(config).next == ("land",)
    assert graph.invoke(None, config)["events"][-1] == "landed"


def test_stream_stops_at_the_breakpoint(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["survey"])
    config = {"configurable": {"thread_id": "stream"}}
    chunks = list(graph.stream(START_INPUT, config, stream_mode="updates"))
    assert chunks == [
        {"plan_route": {"route": ["wp1", "wp2"], "events": ["planned"]}},
        {"takeoff": {"events": ["climbed to 40 m"]}},
        {"__interrupt__": ()},
    ]
    rest = list(graph.stream(None, config, stream_mode="updates"))
    assert rest == [
        {"survey": {"events": ["surveyed wp1+wp2"]}},
        {"land": {"altitude_m": 0, "events": ["landed"]}},
    ]


def test_stream_values_after_the_breakpoint_starts_from_the_paused_state(api: GraphAPI) -> None:
    graph = build_sortie(api, interrupt_before=["survey"])
    config = {"configurable": {"thread_id": "stream-values"}}
    graph.invoke(START_INPUT, config)
    paused = {"altitude_m": 40, "route": ["wp1", "wp2"], "events": ["planned", "climbed to 40 m"]}
    assert list(graph.stream(None, config, stream_mode="values")) == [
        paused,
        {**paused, "events": ["planned", "climbed to 40 m", "surveyed wp1+wp2"]},
        {**paused, "altitude_m": 0, "events": ["planned", "climbed to 40 m", "surveyed wp1+wp2", "landed"]},
    ]
