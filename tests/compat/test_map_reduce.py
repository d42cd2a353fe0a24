"""Map-reduce with Send: one worker task per item, results gathered by a reducer key, then one reduce step."""

import operator
import time
from typing import Annotated, Any, Literal, TypedDict

from .conftest import GraphAPI

# Surface temperature each sector reports, in degrees Celsius.
THERMAL = {"north": 31, "east": 58, "south": 12, "west": 44}


class SurveyState(TypedDict):
    sectors: list[str]
    findings: Annotated[list[dict[str, Any]], operator.add]
    hottest: str


class SectorJob(TypedDict):
    sector: str
    pass_no: int


def scan_sector(job: SectorJob):
    # Later sectors finish first, so results arrive out of order; the reducer must still see Send order.
    time.sleep(0.01 * (len(THERMAL) - list(THERMAL).index(job["sector"])))
    return {"findings": [{"sector": job["sector"], "pass": job["pass_no"], "temp": THERMAL[job["sector"]]}]}


def pick_hottest(state: SurveyState):
    best = max(state["findings"], key=lambda f: f["temp"])
    return {"hottest": best["sector"]}


def build_survey_from_start(api: GraphAPI):
    StateGraph, START, END, Send = api.StateGraph, api.START, api.END, api.Send

    def assign_sectors(state: SurveyState):
        return [Send("scan_sector", {"sector": s, "pass_no": 1}) for s in state["sectors"]]

    builder = StateGraph(SurveyState)
    builder.add_node("scan_sector", scan_sector)
    builder.add_node("pick_hottest", pick_hottest)
    builder.add_conditional_edges(START, assign_sectors, ["scan_sector"])
    builder.add_edge("scan_sector", "pick_hottest")
    builder.add_edge("pick_hottest", END)
    return builder.compile()


def build_survey_from_node(api: GraphAPI):
    StateGraph, START, END, Send = api.StateGraph, api.START, api.END, api.Send

    def plan(state: SurveyState):
        # Survey every sector not yet covered, in the order of THERMAL.
        return {"sectors": [s for s in THERMAL if s not in state["sectors"]]}

    def assign_sectors(state: SurveyState):
        return [Send("scan_sector", {"sector": s, "pass_no": 2}) for s in state["sectors"]]

    builder = StateGraph(SurveyState)
    builder.add_node("plan", plan)
    builder.add_node("scan_sector", scan_sector)
    builder.add_node("pick_hottest", pick_hottest)
    builder.add_edge(START, "plan")
    builder.add_conditional_edges("plan", assign_sectors, ["scan_sector"])
    builder.add_edge("scan_sector", "pick_hottest")
    builder.add_edge("pick_hottest", END)
    return builder.compile()


def build_survey_with_command(api: GraphAPI):
    StateGraph, START, END, Send, Command = api.StateGraph, api.START, api.END, api.Send, api.Command

    # The ignores are for mypy only: `Command` comes from the api fixture, so mypy cannot see it as a type.
    def plan(state: SurveyState) -> Command[Literal["scan_sector"]]:  # type: ignore[valid-type]
        sends = [Send("scan_sector", {"sector": s, "pass_no": 3}) for s in state["sectors"]]
        return Command(update={"findings": []}, goto=sends)  # type: ignore[no-any-return]

    builder = StateGraph(SurveyState)
    builder.add_node("plan", plan)
    builder.add_node("scan_sector", scan_sector)
    builder.add_node("pick_hottest", pick_hottest)
    builder.add_edge(START, "plan")
    builder.add_edge("scan_sector", "pick_hottest")
    builder.add_edge("pick_hottest", END)
    return builder.compile()


def test_send_from_start_maps_and_reduces(api: GraphAPI) -> None:
    graph = build_survey_from_start(api)
    result = graph.invoke({"sectors": ["north", "east", "south", "west"]})
    assert result == {
        "sectors": ["north", "east", "south", "west"],
        "findings": [
            {"sector": "north", "pass": 1, "temp": 31},
            {"sector": "east", "pass": 1, "temp": 58},
            {"sector": "south", "pass": 1, "temp": 12},
            {"sector": "west", "pass": 1, "temp": 44},
        ],
        "hottest": "east",
    }


def test_results_follow_send_order_not_completion_order(api: GraphAPI) -> None:
    graph = build_survey_from_start(api)
    result = graph.invoke({"sectors": ["west", "south", "north"], "findings": []})
    assert [f["sector"] for f in result["findings"]] == ["west", "south", "north"]
    assert result["hottest"] == "west"


def test_same_item_sent_twice_runs_twice(api: GraphAPI) -> None:
    graph = build_survey_from_start(api)
    result = graph.invoke({"sectors": ["south", "south"], "findings": []})
    assert result["findings"] == [
        {"sector": "south", "pass": 1, "temp": 12},
        {"sector": "south", "pass": 1, "temp": 12},
    ]
    assert result["hottest"] == "south"


def test_reduce_node_runs_once_after_all_workers(api: GraphAPI) -> None:
    graph = build_survey_from_start(api)
    chunks = list(graph.stream({"sectors": ["north", "east", "south"], "findings": []}, stream_mode="updates"))
    # The three workers run in one superstep; the order their updates stream in is not fixed.
    workers = sorted(chunks[:3], key=lambda c: c["scan_sector"]["findings"][0]["sector"])
    assert workers == [
        {"scan_sector": {"findings": [{"sector": "east", "pass": 1, "temp": 58}]}},
        {"scan_sector": {"findings": [{"sector": "north", "pass": 1, "temp": 31}]}},
        {"scan_sector": {"findings": [{"sector": "south", "pass": 1, "temp": 12}]}},
    ]
    assert chunks[3:] == [{"pick_hottest": {"hottest": "east"}}]


def test_no_items_means_no_workers_and_no_reduce(api: GraphAPI) -> None:
    graph = build_survey_from_start(api)
    assert graph.invoke({"sectors": []}) == {"sectors": [], "findings": []}


def test_send_from_a_conditional_edge_on_a_node(api: GraphAPI) -> None:
    graph = build_survey_from_node(api)
    result = graph.invoke({"sectors": ["east"], "findings": []})
    assert result == {
        "sectors": ["north", "south", "west"],
        "findings": [
            {"sector": "north", "pass": 2, "temp": 31},
            {"sector": "south", "pass": 2, "temp": 12},
            {"sector": "west", "pass": 2, "temp": 44},
        ],
        "hottest": "west",
    }


def test_send_from_command_goto(api: GraphAPI) -> None:
    graph = build_survey_with_command(api)
    result = graph.invoke({"sectors": ["south", "north"], "findings": []})
    assert result == {
        "sectors": ["south", "north"],
        "findings": [
            {"sector": "south", "pass": 3, "temp": 12},
            {"sector": "north", "pass": 3, "temp": 31},
        ],
        "hottest": "north",
    }
