"""A compiled subgraph as a node of a parent graph: the two share state keys; the subgraph also has its own."""

import operator
from typing import Annotated, TypedDict

from .conftest import GraphAPI


class MissionState(TypedDict):
    battery_pct: int
    checks: Annotated[list[str], operator.add]
    status: str


class PreflightState(TypedDict):
    battery_pct: int
    checks: Annotated[list[str], operator.add]
    gps_satellites: int  # only the subgraph has this key


def build_preflight(api: GraphAPI, *, ask_pilot: bool = False):
    StateGraph, START, END, interrupt = api.StateGraph, api.START, api.END, api.interrupt

    def check_battery(state: PreflightState):
        verdict = "battery ok" if state["battery_pct"] >= 30 else "battery low"
        return {"checks": [verdict]}

    def check_gps(state: PreflightState):
        satellites = 9
        if ask_pilot:
            satellites = interrupt({"ask": "satellites in view?"})
        return {"gps_satellites": satellites, "checks": [f"gps {satellites} sats"]}

    builder = StateGraph(PreflightState)
    builder.add_node("check_battery", check_battery)
    builder.add_node("check_gps", check_gps)
    builder.add_edge(START, "check_battery")
    builder.add_edge("check_battery", "check_gps")
    builder.add_edge("check_gps", END)
    return builder.compile()


def build_mission(api: GraphAPI, *, ask_pilot: bool = False, checkpointer=None):
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def decide(state: MissionState):
        cleared = "battery ok" in state["checks"]
        return {"status": "cleared" if cleared else "hold"}

    builder = StateGraph(MissionState)
    builder.add_node("preflight", build_preflight(api, ask_pilot=ask_pilot))
    builder.add_node("decide", decide)
    builder.add_edge(START, "preflight")
    builder.add_edge("preflight", "decide")
    builder.add_edge("decide", END)
    return builder.compile(checkpointer=checkpointer)


def test_subgraph_node_updates_shared_keys(api: GraphAPI) -> None:
    graph = build_mission(api)
    assert graph.invoke({"battery_pct": 80, "checks": []}) == {
        "battery_pct": 80,
        "checks": ["battery ok", "gps 9 sats"],
        "status": "cleared",
    }


def test_subgraph_private_key_stays_in_the_subgraph(api: GraphAPI) -> None:
    graph = build_mission(api)
    result = graph.invoke({"battery_pct": 12, "checks": []})
    assert "gps_satellites" not in result
    assert result == {"battery_pct": 12, "checks": ["battery low", "gps 9 sats"], "status": "hold"}


def test_subgraph_alone_returns_its_own_state(api: GraphAPI) -> None:
    preflight = build_preflight(api)
    assert preflight.invoke({"battery_pct": 55, "checks": ["armed"]}) == {
        "battery_pct": 55,
        "checks": ["armed", "battery ok", "gps 9 sats"],
        "gps_satellites": 9,
    }


def test_reducer_key_gets_the_subgraphs_whole_list(api: GraphAPI) -> None:
    # The subgraph starts from the parent's list and returns all of it, which the parent's reducer appends.
    graph = build_mission(api)
    result = graph.invoke({"battery_pct": 80, "checks": ["armed"]})
    assert result["checks"] == ["armed", "armed", "battery ok", "gps 9 sats"]


def test_parent_stream_updates_show_the_subgraph_as_one_node(api: GraphAPI) -> None:
    graph = build_mission(api)
    chunks = list(graph.stream({"battery_pct": 80, "checks": []}, stream_mode="updates"))
    assert chunks == [
        {"preflight": {"battery_pct": 80, "checks": ["battery ok", "gps 9 sats"]}},
        {"decide": {"status": "cleared"}},
    ]


def test_stream_with_subgraphs_namespaces_the_inner_updates(api: GraphAPI) -> None:
    graph = build_mission(api)
    chunks = list(graph.stream({"battery_pct": 80, "checks": []}, stream_mode="updates", subgraphs=True))
    # Inner namespaces are "preflight:<task id>"; the task id is random, so compare the node part only.
    seen = [(tuple(part.split(":")[0] for part in ns), update) for ns, update in chunks]
    assert seen == [
        (("preflight",), {"check_battery": {"checks": ["battery ok"]}}),
        (("preflight",), {"check_gps": {"gps_satellites": 9, "checks": ["gps 9 sats"]}}),
        ((), {"preflight": {"battery_pct": 80, "checks": ["battery ok", "gps 9 sats"]}}),
        ((), {"decide": {"status": "cleared"}}),
    ]


def test_interrupt_inside_a_subgraph_pauses_the_parent(api: GraphAPI) -> None:
    graph = build_mission(api, ask_pilot=True, checkpointer=api.InMemorySaver())
    config = {"configurable": {"thread_id": "nested"}}
    paused = graph.invoke({"battery_pct": 80, "checks": []}, config)
    assert [i.value for i in paused["__interrupt__"]] == [{"ask": "satellites in view?"}]
    assert {k: v for k, v in paused.items() if k != "__interrupt__"} == {"battery_pct": 80, "checks": []}
    assert graph.get_state(config).next == ("preflight",)

    final = graph.invoke(api.Command(resume=4), config)
    assert final == {"battery_pct": 80, "checks": ["battery ok", "gps 4 sats"], "status": "cleared"}
    assert graph.get_state(config).next == ()


def test_subgraph_called_from_a_node_with_another_schema(api: GraphAPI) -> None:
    StateGraph, START, END = api.StateGraph, api.START, api.END
    preflight = build_preflight(api)

    class FleetState(TypedDict):
        drones: dict[str, int]
        ready: list[str]

    def run_preflights(state: FleetState):
        ready = []
        for name, battery in state["drones"].items():
            report = preflight.invoke({"battery_pct": battery, "checks": []})
            if "battery ok" in report["checks"]:
                ready.append(name)
        return {"ready": ready}

    builder = StateGraph(FleetState)
    builder.add_node("run_preflights", run_preflights)
    builder.add_edge(START, "run_preflights")
    builder.add_edge("run_preflights", END)
    graph = builder.compile()
    result = graph.invoke({"drones": {"hawk": 90, "wren": 20, "kite": 30}, "ready": []})
    assert result == {"drones": {"hawk": 90, "wren": 20, "kite": 30}, "ready": ["hawk", "kite"]}
