"""An example of the graph runtime alone: a patrol graph (``agentic-uav demo`` and ``make demo`` fly the emergency
mission instead; this module stays as a small library example of the runtime).

It shows the runtime's main features on a search-and-rescue-shaped graph: a plan node fans out one task per
sector with ``Send``, the sector reports merge through a reducer, a router asks for operator approval through
``interrupt`` when a sector reports a casualty, and every superstep is checkpointed in SQLite. No aircraft is
flown and no perception runs here: the sector reports are fixed inputs, say so wherever this is shown.

>>> from agentic_core.demo import build_demo_graph
>>> "plan" in build_demo_graph().get_graph().draw_mermaid()
True
"""

from __future__ import annotations

import operator
import uuid
from pathlib import Path
from typing import Annotated, Any, Literal, TypedDict

from .graph import END, START, Command, CompiledStateGraph, InMemorySaver, Send, SqliteSaver, StateGraph, interrupt
from .graph.checkpoint import BaseCheckpointSaver

SECTOR_REPORTS = {
    "north": "crowd moving normally towards the exit",
    "east": "one person lying motionless, isolated from the crowd",
    "south": "people resting in the shade of the tents",
}


class PatrolState(TypedDict, total=False):
    sectors: list[str]
    reports: Annotated[list[str], operator.add]
    casualties: Annotated[list[str], operator.add]
    approved: bool
    outcome: str


def plan(state: PatrolState) -> dict[str, Any]:
    return {"sectors": sorted(SECTOR_REPORTS)}


def fan_out(state: PatrolState) -> list[Send]:
    return [Send("survey_sector", {"sector": s}) for s in state["sectors"]]


def survey_sector(arg: dict[str, str]) -> dict[str, Any]:
    sector = arg["sector"]
    report = SECTOR_REPORTS[sector]
    casualty = [sector] if "motionless" in report else []
    return {"reports": [f"{sector}: {report}"], "casualties": casualty}


def assess(state: PatrolState) -> dict[str, Any]:
    return {}


def route(state: PatrolState) -> Literal["request_approval", "report"]:
    return "request_approval" if state.get("casualties") else "report"


def request_approval(state: PatrolState) -> Command[Literal["report"]]:
    answer = interrupt({"question": "casualty reported; dispatch the rescue kit?", "sectors": state["casualties"]})
    return Command(update={"approved": answer == "approve"}, goto="report")


def report(state: PatrolState) -> dict[str, Any]:
    if state.get("casualties"):
        verdict = "rescue kit dispatched" if state.get("approved") else "operator declined dispatch"
    else:
        verdict = "no intervention needed"
    return {"outcome": verdict}


def build_demo_graph(checkpointer: BaseCheckpointSaver | None = None) -> CompiledStateGraph:
    """The patrol graph, compiled with ``checkpointer`` (in memory when None)."""
    g = StateGraph(PatrolState)
    g.add_node("plan", plan)
    g.add_node("survey_sector", survey_sector)
    g.add_node("assess", assess)
    g.add_node("request_approval", request_approval)
    g.add_node("report", report)
    g.add_edge(START, "plan")
    g.add_conditional_edges("plan", fan_out, ["survey_sector"])
    g.add_edge("survey_sector", "assess")
    g.add_conditional_edges("assess", route)
    g.add_edge("report", END)
    return g.compile(checkpointer=checkpointer or InMemorySaver())


def run_demo(runs_dir: Path = Path("runs"), *, approve: bool = True, echo: Any = print) -> dict[str, Any]:
    """Run the patrol once, checkpointed under ``runs/<run-id>/``; approve the interrupt by policy."""
    run_id = uuid.uuid4().hex[:8]
    run_dir = runs_dir / run_id
    saver = SqliteSaver(run_dir / "checkpoints.sqlite")
    try:
        app = build_demo_graph(saver)
        config = {"configurable": {"thread_id": run_id}}
        echo(f"demo run {run_id}: a patrol graph on the graph runtime (fixed sector reports, no aircraft flown)")
        for chunk in app.stream({"reports": [], "casualties": []}, config, stream_mode="updates"):
            echo(f"  {chunk}")
        state = app.get_state(config)
        for pending in state.interrupts:
            decision = "approve" if approve else "decline"
            echo(f"  paused for the operator: {pending.value}; headless policy answers {decision!r}")
            for chunk in app.stream(Command(resume=decision), config, stream_mode="updates"):
                echo(f"  {chunk}")
        final = app.get_state(config).values
        steps = len(list(app.get_state_history(config)))
        echo(f"outcome: {final['outcome']} ({steps} checkpoints in {run_dir / 'checkpoints.sqlite'})")
        (run_dir / "graph.mmd").write_text(app.get_graph().draw_mermaid())
        return dict(final)
    finally:
        saver.close()
