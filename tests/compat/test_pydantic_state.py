"""A pydantic BaseModel as the state schema: nodes read attributes, return dicts, defaults fill in."""

import operator
from typing import Annotated, Literal

from pydantic import BaseModel, Field

from .conftest import GraphAPI


class InspectionState(BaseModel):
    asset: str
    passes: int = 0
    defects: Annotated[list[str], operator.add] = Field(default_factory=list)
    verdict: str = "pending"


def build_inspection(api: GraphAPI, *, passes_needed: int = 2):
    StateGraph, START, END = api.StateGraph, api.START, api.END

    def fly_pass(state: InspectionState):
        found = [f"{state.asset} crack {state.passes + 1}"] if state.passes % 2 == 0 else []
        return {"passes": state.passes + 1, "defects": found}

    def enough_passes(state: InspectionState) -> Literal["fly_pass", "report"]:
        return "fly_pass" if state.passes < passes_needed else "report"

    def report(state: InspectionState):
        return {"verdict": f"{len(state.defects)} defect(s) on {state.asset}"}

    builder = StateGraph(InspectionState)
    builder.add_node("fly_pass", fly_pass)
    builder.add_node("report", report)
    builder.add_edge(START, "fly_pass")
    builder.add_conditional_edges("fly_pass", enough_passes)
    builder.add_edge("report", END)
    return builder.compile()


def test_model_state_runs_to_a_plain_dict(api: GraphAPI) -> None:
    graph = build_inspection(api, passes_needed=3)
    result = graph.invoke({"asset": "pylon 7"})
    assert result == {
        "asset": "pylon 7",
        "passes": 3,
        "defects": ["pylon 7 crack 1", "pylon 7 crack 3"],
        "verdict": "2 defect(s) on pylon 7",
    }


def test_model_instance_as_input(api: GraphAPI) -> None:
    graph = build_inspection(api)
    result = graph.invoke(InspectionState(asset="mast", defects=["rust"]))
    assert result == {
        "asset": "mast",
        "passes": 2,
        "defects": ["rust", "mast crack 1"],
        "verdict": "2 defect(s) on mast",
    }


def test_model_state_stream_updates(api: GraphAPI) -> None:
    graph = build_inspection(api)
    chunks = list(graph.stream({"asset": "dam"}, stream_mode="updates"))
    assert chunks == [
        {"fly_pass": {"passes": 1, "defects": ["dam crack 1"]}},
        {"fly_pass": {"passes": 2, "defects": []}},
        {"report": {"verdict": "1 defect(s) on dam"}},
    ]
