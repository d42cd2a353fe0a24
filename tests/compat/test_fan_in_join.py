"""Static fan-out and fan-in: two branches run in one superstep, a join waits for both (add_edge([a, b], c))."""

import operator
from typing import Annotated, TypedDict

from .conftest import GraphAPI


class SensorState(TypedDict):
    target: str
    readings: Annotated[list[str], operator.add]
    fused: str


def build_sensor_fusion(api: GraphAPI, *, slow_lidar: bool = False):
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def camera(state: SensorState):
        return {"readings": [f"camera:{state['target']}"]}

    def lidar(state: SensorState):
        return {"readings": [f"lidar:{state['target']}"]}

    def lidar_filter(state: SensorState):
        return {"readings": ["lidar:filtered"]}

    def fuse(state: SensorState):
        return {"fused": " & ".join(sorted(state["readings"]))}

    builder = StateGraph(SensorState)
    builder.add_node("lidar", lidar)
    builder.add_node("camera", camera)
    builder.add_node("fuse", fuse)
    builder.add_edge(START, "lidar")
    builder.add_edge(START, "camera")
    if slow_lidar:
        builder.add_node("lidar_filter", lidar_filter)
        builder.add_edge("lidar", "lidar_filter")
        builder.add_edge(["camera", "lidar_filter"], "fuse")
    else:
        builder.add_edge(["camera", "lidar"], "fuse")
    builder.add_edge("fuse", END)
    return builder.compile()


def test_join_runs_once_after_both_branches(api: GraphAPI) -> None:
    graph = build_sensor_fusion(api)
    chunks = list(graph.stream({"target": "roof", "readings": []}, stream_mode="updates"))
    assert sorted(next(iter(c)) for c in chunks[:2]) == ["camera", "lidar"]
    assert chunks[2:] == [{"fuse": {"fused": "camera:roof & lidar:roof"}}]
    result = graph.invoke({"target": "roof", "readings": []})
    assert sorted(result["readings"]) == ["camera:roof", "lidar:roof"]
    assert result["fused"] == "camera:roof & lidar:roof"


def test_join_waits_for_the_longer_branch(api: GraphAPI) -> None:
    graph = build_sensor_fusion(api, slow_lidar=True)
    chunks = list(graph.stream({"target": "roof", "readings": []}, stream_mode="updates"))
    first_step = sorted(chunks[:2], key=lambda c: next(iter(c)))
    assert first_step == [
        {"camera": {"readings": ["camera:roof"]}},
        {"lidar": {"readings": ["lidar:roof"]}},
    ]
    assert chunks[2:] == [
        {"lidar_filter": {"readings": ["lidar:filtered"]}},
        {"fuse": {"fused": "camera:roof & lidar:filtered & lidar:roof"}},
    ]


def test_parallel_writes_to_a_reducer_key_are_applied_in_node_name_order(api: GraphAPI) -> None:
    # "lidar" is added first, but LangGraph applies a superstep's writes sorted by task path (the node name).
    graph = build_sensor_fusion(api)
    assert graph.invoke({"target": "tank", "readings": ["gps:fix"]})["readings"] == [
        "gps:fix",
        "camera:tank",
        "lidar:tank",
    ]
