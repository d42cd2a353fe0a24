"""Human approval: a node pauses with interrupt(), the caller resumes it with Command(resume=...).

The review node routes with ``Command(goto=...)`` to one of two branches, declared by its return annotation.
"""

import operator
from typing import Annotated, Literal, TypedDict

from .conftest import GraphAPI


class FlightPlanState(TypedDict):
    mission: str
    plan: str
    verdict: str
    status: str
    log: Annotated[list[str], operator.add]


def build_approval_flow(api: GraphAPI, *, review_calls: list[str] | None = None):
    StateGraph, START, END = api.StateGraph, api.START, api.END
    Command, interrupt, InMemorySaver = api.Command, api.interrupt, api.InMemorySaver

    def draft_plan(state: FlightPlanState):
        return {"plan": f"survey {state['mission']} at 40 m AGL", "log": ["drafted"]}

    # The ignores are for mypy only: `Command` comes from the api fixture, so mypy cannot see it as a type.
    def operator_review(state: FlightPlanState) -> Command[Literal["launch", "stand_down"]]:  # type: ignore[valid-type]
        if review_calls is not None:
            review_calls.append(state["plan"])  # runs again on resume: the node restarts from the top
        answer = interrupt({"question": "Approve this flight plan?", "plan": state["plan"]})
        if answer == "approve":
            verdict, next_node = "approved", "launch"
        else:
            verdict, next_node = f"rejected: {answer}", "stand_down"
        return Command(update={"verdict": verdict, "log": ["reviewed"]}, goto=next_node)  # type: ignore[no-any-return]

    def launch(state: FlightPlanState):
        return {"status": "airborne", "log": ["launched"]}

    def stand_down(state: FlightPlanState):
        return {"status": "grounded", "log": ["stood down"]}

    builder = StateGraph(FlightPlanState)
    builder.add_node("draft_plan", draft_plan)
    builder.add_node("operator_review", operator_review)
    builder.add_node("launch", launch)
    builder.add_node("stand_down", stand_down)
    builder.add_edge(START, "draft_plan")
    builder.add_edge("draft_plan", "operator_review")
    builder.add_edge("launch", END)
    builder.add_edge("stand_down", END)
    return builder.compile(checkpointer=InMemorySaver())


QUESTION = {"question": "Approve this flight plan?", "plan": "survey orchard at 40 m AGL"}
PAUSED = {"mission": "orchard", "plan": "survey orchard at 40 m AGL", "log": ["drafted"]}


def _pause(graph, thread_id: str):
    config = {"configurable": {"thread_id": thread_id}}
    result = graph.invoke({"mission": "orchard", "log": []}, config)
    return config, result


def test_interrupt_pauses_and_reports_the_question(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    _, result = _pause(graph, "pause")
    interrupts = result.pop("__interrupt__")
    assert result == PAUSED
    assert len(interrupts) == 1
    assert interrupts[0].value == QUESTION
    assert isinstance(interrupts[0].id, str)
    assert interrupts[0].id


def test_paused_thread_state(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config, result = _pause(graph, "state")
    snapshot = graph.get_state(config)
    assert snapshot.next == ("operator_review",)
    assert snapshot.values == PAUSED
    assert [t.name for t in snapshot.tasks] == ["operator_review"]
    assert [i.value for i in snapshot.tasks[0].interrupts] == [QUESTION]
    assert [i.value for i in snapshot.interrupts] == [QUESTION]
    assert snapshot.interrupts[0].id == result["__interrupt__"][0].id


def test_approve_resumes_into_launch(api: GraphAPI) -> None:
    calls: list[str] = []
    graph = build_approval_flow(api, review_calls=calls)
    config, _ = _pause(graph, "approve")
    final = graph.invoke(api.Command(resume="approve"), config)
    assert final == {
        "mission": "orchard",
        "plan": "survey orchard at 40 m AGL",
        "verdict": "approved",
        "status": "airborne",
        "log": ["drafted", "reviewed", "launched"],
    }
    assert graph.get_state(config).next == ()
    assert graph.get_state(config).values == final
    # The review node ran twice: once up to the interrupt, once again on resume.
    assert calls == ["survey orchard at 40 m AGL", "survey orchard at 40 m AGL"]


def test_reject_resumes_into_stand_down(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config, _ = _pause(graph, "reject")
    final = graph.invoke(api.Command(resume="wind too strong"), config)
    assert final == {
        "mission": "orchard",
        "plan": "survey orchard at 40 m AGL",
        "verdict": "rejected: wind too strong",
        "status": "grounded",
        "log": ["drafted", "reviewed", "stood down"],
    }
    assert graph.get_state(config).next == ()


def test_threads_pause_and_resume_independently(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config_a, _ = _pause(graph, "thread-a")
    config_b, _ = _pause(graph, "thread-b")
    assert graph.invoke(api.Command(resume="no"), config_b)["status"] == "grounded"
    assert graph.get_state(config_a).next == ("operator_review",)
    assert graph.invoke(api.Command(resume="approve"), config_a)["status"] == "airborne"


def test_stream_updates_through_pause_and_resume(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config = {"configurable": {"thread_id": "stream"}}
    first = list(graph.stream({"mission": "orchard", "log": []}, config, stream_mode="updates"))
    assert len(first) == 2
    assert first[0] == {"draft_plan": {"plan": "survey orchard at 40 m AGL", "log": ["drafted"]}}
    assert list(first[1]) == ["__interrupt__"]
    assert isinstance(first[1]["__interrupt__"], tuple)
    assert [i.value for i in first[1]["__interrupt__"]] == [QUESTION]

    second = list(graph.stream(api.Command(resume="approve"), config, stream_mode="updates"))
    assert second == [
        {"operator_review": {"verdict": "approved", "log": ["reviewed"]}},
        {"launch": {"status": "airborne", "log": ["launched"]}},
    ]


def test_stream_values_ends_with_the_interrupt(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config = {"configurable": {"thread_id": "values-pause"}}
    chunks = list(graph.stream({"mission": "orchard", "log": []}, config, stream_mode="values"))
    assert chunks[:2] == [{"mission": "orchard", "log": []}, PAUSED]
    assert len(chunks) == 3
    last = dict(chunks[2])
    interrupts = last.pop("__interrupt__")
    assert last == PAUSED
    assert [i.value for i in interrupts] == [QUESTION]


def test_stream_values_on_resume_starts_from_the_paused_state(api: GraphAPI) -> None:
    graph = build_approval_flow(api)
    config = {"configurable": {"thread_id": "values-resume"}}
    graph.invoke({"mission": "orchard", "log": []}, config)
    chunks = list(graph.stream(api.Command(resume="approve"), config, stream_mode="values"))
    assert chunks == [
        PAUSED,
        {**PAUSED, "verdict": "approved", "log": ["drafted", "reviewed"]},
        {**PAUSED, "verdict": "approved", "status": "airborne", "log": ["drafted", "reviewed", "launched"]},
    ]


def test_resume_value_reaches_a_second_interrupt(api: GraphAPI) -> None:
    StateGraph, START, END = api.StateGraph, api.START, api.END
    Command, interrupt, InMemorySaver = api.Command, api.interrupt, api.InMemorySaver

    class Checklist(TypedDict):
        answers: list[str]

    def ask_twice(state: Checklist):
        pilot = interrupt("pilot name?")
        site = interrupt(f"site for {pilot}?")
        return {"answers": [pilot, site]}

    builder = StateGraph(Checklist)
    builder.add_node("ask_twice", ask_twice)
    builder.add_edge(START, "ask_twice")
    builder.add_edge("ask_twice", END)
    graph = builder.compile(checkpointer=InMemorySaver())
    config = {"configurable": {"thread_id": "two-questions"}}

    first = graph.invoke({"answers": []}, config)
    assert [i.value for i in first["__interrupt__"]] == ["pilot name?"]
    second = graph.invoke(Command(resume="Ada"), config)
    assert [i.value for i in second["__interrupt__"]] == ["site for Ada?"]
    assert graph.get_state(config).next == ("ask_twice",)
    assert graph.invoke(Command(resume="field 7"), config) == {"answers": ["Ada", "field 7"]}


def test_parallel_interrupts_resume_by_id(api: GraphAPI) -> None:
    StateGraph, START, END = api.StateGraph, api.START, api.END
    Command, interrupt, InMemorySaver = api.Command, api.interrupt, api.InMemorySaver

    class SignOff(TypedDict):
        signatures: Annotated[list[str], operator.add]

    def safety_officer(state: SignOff):
        return {"signatures": [f"safety:{interrupt('safety officer sign-off?')}"]}

    def airspace_manager(state: SignOff):
        return {"signatures": [f"airspace:{interrupt('airspace manager sign-off?')}"]}

    builder = StateGraph(SignOff)
    builder.add_node("airspace_manager", airspace_manager)
    builder.add_node("safety_officer", safety_officer)
    builder.add_edge(START, "airspace_manager")
    builder.add_edge(START, "safety_officer")
    builder.add_edge("airspace_manager", END)
    builder.add_edge("safety_officer", END)
    graph = builder.compile(checkpointer=InMemorySaver())
    config = {"configurable": {"thread_id": "two-signatures"}}

    paused = graph.invoke({"signatures": []}, config)
    by_question = {i.value: i.id for i in paused["__interrupt__"]}
    assert sorted(by_question) == ["airspace manager sign-off?", "safety officer sign-off?"]
    assert sorted(graph.get_state(config).next) == ["airspace_manager", "safety_officer"]

    answers = {
        by_question["safety officer sign-off?"]: "yes",
        by_question["airspace manager sign-off?"]: "cleared",
    }
    final = graph.invoke(Command(resume=answers), config)
    assert final == {"signatures": ["airspace:cleared", "safety:yes"]}
    assert graph.get_state(config).next == ()
