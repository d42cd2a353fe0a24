"""interrupt() and Command(resume=...), breakpoints, and the rule that only the interrupted node re-runs."""

import operator
from typing import Annotated, Any, Literal, TypedDict

import pytest

from agentic_core.graph import (
    END,
    START,
    BaseCheckpointSaver,
    CheckpointError,
    Command,
    GraphError,
    InMemorySaver,
    StateGraph,
    interrupt,
)


class S(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    answer: str


def cfg(thread: str = "t") -> dict[str, Any]:
    return {"configurable": {"thread_id": thread}}


def test_only_the_interrupted_node_reruns_and_no_other_side_effect_repeats(saver: BaseCheckpointSaver) -> None:
    effects: list[str] = []

    def deploy(state: S) -> dict[str, list[str]]:
        effects.append("deploy")  # a side effect that must happen exactly once
        return {"log": ["deployed"]}

    def ask(state: S) -> dict[str, str]:
        effects.append("ask:before")  # code before interrupt() runs again on resume, by design
        answer = interrupt("land near the crowd?")
        effects.append(f"ask:after:{answer}")
        return {"answer": answer}

    def finish(state: S) -> dict[str, list[str]]:
        effects.append("finish")
        return {"log": ["done"]}

    g = StateGraph(S)
    g.add_node("deploy", deploy)
    g.add_node("ask", ask)
    g.add_node("finish", finish)
    g.add_edge(START, "deploy")
    g.add_edge(START, "ask")
    g.add_edge(["deploy", "ask"], "finish")
    g.add_edge("finish", END)
    app = g.compile(checkpointer=saver)

    first = app.invoke({"log": []}, cfg())
    assert [i.value for i in first["__interrupt__"]] == ["land near the crowd?"]
    # the barrier was not passed: deploy's write is held as a pending write, shown (as LangGraph shows it)
    assert first["log"] == ["deployed"]
    snap = app.get_state(cfg())
    assert snap.values["log"] == ["deployed"]
    assert snap.next == ("ask",)  # deploy finished; only the paused task is still to run
    assert [i.value for i in snap.interrupts] == ["land near the crowd?"]

    final = app.invoke(Command(resume="yes"), cfg())
    assert final == {"log": ["deployed", "done"], "answer": "yes"}
    # deploy and ask ran concurrently in the first superstep, so only counts are fixed before the resume
    assert sorted(effects[:2]) == ["ask:before", "deploy"]
    assert effects[2:] == ["ask:before", "ask:after:yes", "finish"]


def test_several_interrupts_in_one_node_resume_in_order(saver: BaseCheckpointSaver) -> None:
    def checklist(state: S) -> dict[str, str]:
        a = interrupt("battery ok?")
        b = interrupt("area clear?")
        return {"answer": f"{a}/{b}"}

    g = StateGraph(S)
    g.add_node("checklist", checklist)
    g.add_edge(START, "checklist")
    g.add_edge("checklist", END)
    app = g.compile(checkpointer=saver)
    assert app.invoke({"log": []}, cfg())["__interrupt__"][0].value == "battery ok?"
    assert app.invoke(Command(resume="yes"), cfg())["__interrupt__"][0].value == "area clear?"
    assert app.invoke(Command(resume="clear"), cfg())["answer"] == "yes/clear"


def test_parallel_interrupts_resume_by_id(saver: BaseCheckpointSaver) -> None:
    g = StateGraph(S)
    g.add_node("left", lambda s: {"log": [f"left:{interrupt('left?')}"]})
    g.add_node("right", lambda s: {"log": [f"right:{interrupt('right?')}"]})
    g.add_edge(START, "left")
    g.add_edge(START, "right")
    g.add_edge("left", END)
    g.add_edge("right", END)
    app = g.compile(checkpointer=saver)
    pending = app.invoke({"log": []}, cfg())["__interrupt__"]
    assert sorted(i.value for i in pending) == ["left?", "right?"]
    with pytest.raises(GraphError, match="2 interrupts are pending"):
        app.invoke(Command(resume="x"), cfg())
    answers = {i.id: i.value.upper() for i in pending}
    assert app.invoke(Command(resume=answers), cfg())["log"] == ["left:LEFT?", "right:RIGHT?"]


def test_approval_node_routes_with_command(saver: BaseCheckpointSaver) -> None:
    def approval(state: S) -> Command[Literal["land", "hold"]]:
        ok = interrupt({"action": "land", "near": "crowd"})
        return Command(goto="land" if ok else "hold")

    g = StateGraph(S)
    g.add_node("approval", approval)
    g.add_node("land", lambda s: {"log": ["landed"]})
    g.add_node("hold", lambda s: {"log": ["holding"]})
    g.add_edge(START, "approval")
    g.add_edge("land", END)
    g.add_edge("hold", END)
    app = g.compile(checkpointer=saver)
    app.invoke({"log": []}, cfg("yes"))
    app.invoke({"log": []}, cfg("no"))
    assert app.invoke(Command(resume=True), cfg("yes"))["log"] == ["landed"]
    assert app.invoke(Command(resume=False), cfg("no"))["log"] == ["holding"]


def breakpoints(saver: BaseCheckpointSaver, **kw: Any) -> Any:
    g = StateGraph(S)
    for name in ("takeoff", "land", "report"):
        g.add_node(name, lambda s, n=name: {"log": [n]})
    g.add_edge(START, "takeoff")
    g.add_edge("takeoff", "land")
    g.add_edge("land", "report")
    g.add_edge("report", END)
    return g.compile(checkpointer=saver, **kw)


def test_interrupt_before_stops_and_none_continues(saver: BaseCheckpointSaver) -> None:
    app = breakpoints(saver, interrupt_before=["land"])
    assert app.invoke({"log": []}, cfg()) == {"log": ["takeoff"]}
    assert app.get_state(cfg()).next == ("land",)
    assert app.invoke(None, cfg()) == {"log": ["takeoff", "land", "report"]}


def test_interrupt_after_stops_after_the_node(saver: BaseCheckpointSaver) -> None:
    app = breakpoints(saver, interrupt_after=["takeoff"])
    assert app.invoke({"log": []}, cfg()) == {"log": ["takeoff"]}
    assert app.get_state(cfg()).next == ("land",)
    assert app.invoke(None, cfg())["log"] == ["takeoff", "land", "report"]


def test_a_breakpoint_pause_is_in_the_checkpoint_so_a_new_process_sees_it(saver: BaseCheckpointSaver) -> None:
    """A restarted process (here: a freshly compiled graph on the same saver) finds the run paused before the
    breakpoint node, and one invoke(None) continues it; no duplicate checkpoint is written for the pause."""
    breakpoints(saver, interrupt_before=["land"]).invoke({"log": []}, cfg())
    restarted = breakpoints(saver, interrupt_before=["land"])
    assert restarted.get_state(cfg()).next == ("land",)
    assert [h.next for h in restarted.get_state_history(cfg())] == [("land",), ("takeoff",), ("__start__",)]
    assert restarted.invoke(None, cfg()) == {"log": ["takeoff", "land", "report"]}


def test_interrupt_after_then_before_is_one_pause(saver: BaseCheckpointSaver) -> None:
    app = breakpoints(saver, interrupt_after=["takeoff"], interrupt_before=["land"])
    assert app.invoke({"log": []}, cfg()) == {"log": ["takeoff"]}
    assert app.invoke(None, cfg()) == {"log": ["takeoff", "land", "report"]}


def test_interrupt_needs_a_checkpointer() -> None:
    g = StateGraph(S)
    g.add_node("ask", lambda s: {"answer": interrupt("?")})
    g.add_edge(START, "ask")
    g.add_edge("ask", END)
    with pytest.raises(CheckpointError, match="node 'ask' called interrupt"):
        g.compile().invoke({"log": []})


def test_resume_without_a_pending_interrupt(saver: BaseCheckpointSaver) -> None:
    app = breakpoints(saver)
    app.invoke({"log": []}, cfg())
    with pytest.raises(GraphError, match="no interrupt is pending"):
        app.invoke(Command(resume="x"), cfg())


def test_interrupt_inside_a_subgraph_resumes_through_the_parent() -> None:
    effects: list[str] = []
    sub = StateGraph(S)

    def prepare(state: S) -> dict[str, list[str]]:
        effects.append("prepare")
        return {"log": ["prepared"]}

    sub.add_node("prepare", prepare)
    sub.add_node("confirm", lambda s: {"answer": interrupt("release payload?")})
    sub.add_edge(START, "prepare")
    sub.add_edge("prepare", "confirm")
    sub.add_edge("confirm", END)
    g = StateGraph(S)
    g.add_node("payload", sub.compile())
    g.add_node("after", lambda s: {"log": [f"after:{s['answer']}"]})
    g.add_edge(START, "payload")
    g.add_edge("payload", "after")
    g.add_edge("after", END)
    app = g.compile(checkpointer=InMemorySaver())
    first = app.invoke({"log": []}, cfg())
    assert first["__interrupt__"][0].value == "release payload?"
    final = app.invoke(Command(resume="go"), cfg())
    assert final["answer"] == "go" and final["log"][-1] == "after:go"
    assert effects == ["prepare"]  # the subgraph's finished node did not run again


def test_command_parent_routes_in_the_parent_graph() -> None:
    sub = StateGraph(S)
    sub.add_node("escalate", lambda s: Command(graph=Command.PARENT, goto="alarm", update={"answer": "abort"}))
    sub.add_edge(START, "escalate")
    sub.add_edge("escalate", END)
    g = StateGraph(S)
    g.add_node("inner", sub.compile(), destinations=("alarm",))
    g.add_node("alarm", lambda s: {"log": ["alarm"]})
    g.add_edge(START, "inner")
    g.add_edge("alarm", END)
    assert g.compile().invoke({"log": []}) == {"log": ["alarm"], "answer": "abort"}
