"""Edge cases found in review: isolation between runs, edits of paused runs, async subgraphs, odd schemas."""

import asyncio
import operator
from typing import Annotated, Any, Literal, NotRequired, Optional, TypedDict

import pytest
from pydantic import BaseModel, Field, field_validator

from agentic_core.graph import (
    END,
    START,
    BaseCheckpointSaver,
    Command,
    GraphError,
    InMemorySaver,
    RetryPolicy,
    StateGraph,
    StateTypeError,
    get_stream_writer,
    interrupt,
)
from agentic_core.graph.types import default_retry_on
from tests.waiting import wait_for_async


def cfg(thread: Any = "t") -> dict[str, Any]:
    return {"configurable": {"thread_id": thread}}


def single(schema: Any, fn: Any, **compile_kw: Any) -> Any:
    g = StateGraph(schema)
    g.add_node("n", fn)
    g.add_edge(START, "n")
    g.add_edge("n", END)
    return g.compile(**compile_kw)


def merge_in_place(left: dict[str, int], right: dict[str, int]) -> dict[str, int]:
    left.update(right)
    return left


class Seen(TypedDict, total=False):
    seen: Annotated[dict[str, int], merge_in_place]
    q: str


class Defaults(BaseModel):
    q: str = ""
    log: list[str] = []


def test_starting_values_are_fresh_for_every_run() -> None:
    app = single(Seen, lambda s: {"seen": {s["q"]: 1}})
    app.invoke({"q": "first"})
    assert app.invoke({"q": "second"})["seen"] == {"second": 1}

    def append_in_place(state: Defaults) -> dict[str, Any]:
        state.log.append(state.q)
        return {"log": state.log}

    model_app = single(Defaults, append_in_place)
    model_app.invoke({"q": "first"})
    assert model_app.invoke({"q": "second"})["log"] == ["second"]


def push(left: list[str], right: str | list[str]) -> list[str]:
    left.extend(right if isinstance(right, list) else [right])
    return left


class Pushed(TypedDict, total=False):
    log: Annotated[list[str], push]


def test_an_in_place_reducer_is_applied_once_per_write() -> None:
    g = StateGraph(Pushed)
    g.add_node("one", lambda s: {"log": "one"})
    g.add_node("two", lambda s: {"log": "two"})
    g.add_edge(START, "one").add_edge("one", "two").add_edge("two", END)
    assert g.compile().invoke({"log": ["in"]}) == {"log": ["in", "one", "two"]}


class Maybe(TypedDict, total=False):
    items: Optional[list[str]]  # noqa: UP045 - the Optional spelling users write
    step: int


def test_a_list_key_that_was_none_in_between_is_checkpointed_right(saver: BaseCheckpointSaver) -> None:
    values: list[list[str] | None] = [["a", "b"], None, ["a", "b", "c"]]
    g = StateGraph(Maybe)
    g.add_node("n", lambda s: {"items": values[s["step"]], "step": s["step"] + 1})
    g.add_edge(START, "n")
    g.add_conditional_edges("n", lambda s: "n" if s["step"] < 3 else END, ["n", END])
    app = g.compile(checkpointer=saver)
    app.invoke({"step": 0}, cfg())
    assert app.get_state(cfg()).values["items"] == ["a", "b", "c"]


class Sub(TypedDict, total=False):
    x: int
    y: int


def test_a_fork_before_a_subgraph_runs_the_subgraph_on_the_new_values() -> None:
    sub = StateGraph(Sub)
    sub.add_node("double", lambda s: {"y": s["x"] * 2})
    sub.add_edge(START, "double").add_edge("double", END)
    g = StateGraph(Sub)
    g.add_node("prep", lambda s: {"x": s["x"] + 1})
    g.add_node("sub", sub.compile())
    g.add_edge(START, "prep").add_edge("prep", "sub").add_edge("sub", END)
    app = g.compile(checkpointer=InMemorySaver())
    assert app.invoke({"x": 1}, cfg()) == {"x": 2, "y": 4}
    before_sub = next(s for s in app.get_state_history(cfg()) if s.next == ("sub",))
    fork = app.update_state(before_sub.config, {"x": 100})
    assert app.invoke(None, fork) == {"x": 100, "y": 200}


class Paused(TypedDict, total=False):
    log: Annotated[list[str], operator.add]
    note: str
    plan: str
    ok: str


def parallel_with_checklist(saver: BaseCheckpointSaver, calls: list[str]) -> Any:
    def a(state: Paused) -> dict[str, list[str]]:
        calls.append("a")
        return {"log": ["a"]}

    def b(state: Paused) -> dict[str, list[str]]:
        calls.append("b")
        return {"log": [f"b:{interrupt('first?')}{interrupt('second?')}"]}

    g = StateGraph(Paused)
    g.add_node("a", a).add_node("b", b)
    g.add_edge(START, "a").add_edge(START, "b").add_edge("a", END).add_edge("b", END)
    return g.compile(checkpointer=saver)


def test_resume_with_an_update_keeps_finished_siblings_done(saver: BaseCheckpointSaver) -> None:
    calls: list[str] = []
    app = parallel_with_checklist(saver, calls)
    app.invoke({"log": []}, cfg())
    app.invoke(Command(resume="x", update={"note": "u"}), cfg())
    out = app.invoke(Command(resume="y"), cfg())
    assert out == {"log": ["a", "b:xy"], "note": "u"}
    assert calls == ["a", "b", "b", "b"] or calls == ["b", "a", "b", "b"]


def test_an_answer_survives_an_error_after_the_resume(saver: BaseCheckpointSaver) -> None:
    failures = [ConnectionError("autopilot link dropped")]

    def land(state: Paused) -> dict[str, str]:
        ok = interrupt("approve?")
        if failures:
            raise failures.pop()
        return {"ok": f"landed ({ok})"}

    app = single(Paused, land, checkpointer=saver)
    app.invoke({"log": []}, cfg())
    with pytest.raises(ConnectionError):
        app.invoke(Command(resume="yes"), cfg())
    assert app.invoke(None, cfg())["ok"] == "landed (yes)"


def test_editing_a_run_paused_in_interrupt_keeps_the_pause(saver: BaseCheckpointSaver) -> None:
    g = StateGraph(Paused)
    g.add_node("draft", lambda s: {"plan": "p1"})
    g.add_node("review", lambda s: {"ok": f"{s['plan']}:{interrupt('approve?')}"})
    g.add_edge(START, "draft").add_edge("draft", "review").add_edge("review", END)
    app = g.compile(checkpointer=saver)
    app.invoke({"log": []}, cfg())
    app.update_state(cfg(), {"plan": "p2"})
    snap = app.get_state(cfg())
    assert snap.next == ("review",) and [i.value for i in snap.interrupts] == ["approve?"]
    assert app.invoke(Command(resume="yes"), cfg())["ok"] == "p2:yes"


def test_update_state_without_as_node_reroutes_from_the_last_node(saver: BaseCheckpointSaver) -> None:
    class R(TypedDict, total=False):
        use_tools: bool

    g = StateGraph(R)
    g.add_node("agent", lambda s: None).add_node("tools", lambda s: None).add_node("other", lambda s: None)
    g.add_edge(START, "agent").add_edge("tools", END).add_edge("other", END)
    g.add_conditional_edges("agent", lambda s: "tools" if s["use_tools"] else "other", ["tools", "other"])
    app = g.compile(checkpointer=saver, interrupt_after=["agent"])
    app.invoke({"use_tools": True}, cfg())
    assert app.get_state(cfg()).next == ("tools",)
    app.update_state(cfg(), {"use_tools": False})
    assert app.get_state(cfg()).next == ("other",)


@pytest.mark.parametrize("where", ["interrupt_before", "interrupt_after"])
def test_star_breakpoints_do_not_stop_at_the_input_step(saver: BaseCheckpointSaver, where: str) -> None:
    class N(TypedDict, total=False):
        n: int

    g = StateGraph(N)
    g.add_node("a", lambda s: {"n": s["n"] + 1}).add_node("b", lambda s: {"n": s["n"] * 10})
    g.add_edge(START, "a").add_edge("a", "b").add_edge("b", END)
    breakpoint_kw: dict[str, Any] = {where: "*"}
    app = g.compile(checkpointer=saver, **breakpoint_kw)
    first = app.invoke({"n": 1}, cfg())
    assert first == ({"n": 1} if where == "interrupt_before" else {"n": 2})
    assert app.get_state(cfg()).next == (("a",) if where == "interrupt_before" else ("b",))


def test_an_integer_thread_id_works_everywhere() -> None:
    app = single(Paused, lambda s: {"note": "x"}, checkpointer=InMemorySaver())
    app.invoke({"log": []}, cfg(7))
    assert app.get_state(cfg(7)).values["note"] == "x"
    assert len(list(app.get_state_history(cfg(7)))) == 3


def test_async_router_under_ainvoke() -> None:
    class N(TypedDict, total=False):
        n: int

    async def route(state: N) -> Literal["b", "__end__"]:
        await asyncio.sleep(0)
        return "b"

    g = StateGraph(N)
    g.add_node("a", lambda s: {"n": 1}).add_node("b", lambda s: {"n": s["n"] + 1})
    g.add_edge(START, "a").add_conditional_edges("a", route).add_edge("b", END)
    assert asyncio.run(g.compile().ainvoke({"n": 0})) == {"n": 2}


def test_async_nodes_in_a_subgraph_run_on_the_callers_loop() -> None:
    class AB(TypedDict, total=False):
        a: int
        b: int

    async def main() -> dict[str, Any]:
        lock = asyncio.Lock()  # bound to this loop: a node on another loop could not use it

        def node(key: str) -> Any:
            async def fn(state: AB) -> dict[str, int]:
                async with lock:
                    await asyncio.sleep(0.01)
                return {key: 1}

            return fn

        sub = StateGraph(AB)
        sub.add_node("inner", node("b")).add_edge(START, "inner").add_edge("inner", END)
        g = StateGraph(AB)
        g.add_node("sub", sub.compile()).add_node("top", node("a"))
        g.add_edge(START, "sub").add_edge(START, "top").add_edge("sub", END).add_edge("top", END)
        return await asyncio.wait_for(g.compile().ainvoke({}), 10)

    assert asyncio.run(main()) == {"a": 1, "b": 1}


def test_cancelling_ainvoke_cancels_its_running_nodes() -> None:
    effects: list[str] = []

    class E(TypedDict, total=False):
        x: int

    async def fast(state: E) -> None:
        effects.append("fast")

    async def slow(state: E) -> None:
        try:
            await asyncio.sleep(0.5)
        except asyncio.CancelledError:
            effects.append("cancelled")
            raise
        effects.append("slow")

    g = StateGraph(E)
    g.add_node("fast", fast).add_node("slow", slow)
    g.add_edge(START, "fast").add_edge(START, "slow").add_edge("fast", END).add_edge("slow", END)

    async def main() -> None:
        with pytest.raises(TimeoutError):
            await asyncio.wait_for(g.compile().ainvoke({}), 0.1)
        await wait_for_async(lambda: "cancelled" in effects, 5, what="the slow node to be cancelled")

    asyncio.run(main())
    assert effects == ["fast", "cancelled"]


def test_astream_custom_chunks_come_before_the_nodes_update() -> None:
    class N(TypedDict, total=False):
        n: int

    async def step(state: N) -> dict[str, int]:
        get_stream_writer()("done")
        return {"n": 1}

    app = single(N, step)

    async def collect() -> list[Any]:
        return [c async for c in app.astream({"n": 0}, stream_mode=["custom", "updates"])]

    assert asyncio.run(collect()) == [("custom", "done"), ("updates", {"n": {"n": 1}})]


def test_parallel_interrupts_inside_a_subgraph_resume_by_id() -> None:
    class A(TypedDict, total=False):
        answers: Annotated[list[str], operator.add]

    sub = StateGraph(A)
    sub.add_node("a", lambda s: {"answers": [f"a={interrupt('a')}"]})
    sub.add_node("b", lambda s: {"answers": [f"b={interrupt('b')}"]})
    sub.add_edge(START, "a").add_edge(START, "b").add_edge("a", END).add_edge("b", END)
    g = StateGraph(A)
    g.add_node("sub", sub.compile()).add_edge(START, "sub").add_edge("sub", END)
    app = g.compile(checkpointer=InMemorySaver())
    pending = app.invoke({"answers": []}, cfg())["__interrupt__"]
    out = app.invoke(Command(resume={i.id: i.value.upper() for i in pending}), cfg())
    assert out["answers"] == ["a=A", "b=B"]


def test_checkpointer_true_gives_a_subgraph_memory_across_calls() -> None:
    class Outer(TypedDict, total=False):
        total: int

    class Inner(TypedDict, total=False):
        total: int
        seen: Annotated[int, operator.add]  # private to the subgraph

    def count(state: Inner) -> dict[str, int]:
        return {"seen": 1, "total": state["seen"] + 1}

    def totals(checkpointer: Any) -> list[int]:
        sub = StateGraph(Inner)
        sub.add_node("count", count).add_edge(START, "count").add_edge("count", END)
        g = StateGraph(Outer)
        g.add_node("sub", sub.compile(checkpointer=checkpointer)).add_edge(START, "sub").add_edge("sub", END)
        app = g.compile(checkpointer=InMemorySaver())
        return [app.invoke({}, cfg())["total"] for _ in range(3)]

    assert totals(True) == [1, 2, 3]  # one namespace per node: the subgraph remembers
    assert totals(None) == [1, 1, 1]  # a namespace per call: it starts afresh each time
    sub = StateGraph(Inner)
    sub.add_node("count", count).add_edge(START, "count").add_edge("count", END)
    with pytest.raises(GraphError, match="checkpointer=True"):
        sub.compile(checkpointer=True).invoke({})


class Flexible(TypedDict):
    q: str
    log: NotRequired[Annotated[list[str], operator.add]]
    n: NotRequired[int]


class Drone:
    """A plain class pydantic knows nothing about."""


class WithObject(TypedDict, total=False):
    drone: Drone


def test_notrequired_keys_and_plain_class_values() -> None:
    app = single(Flexible, lambda s: {"log": ["b"], "n": 1})
    assert app.invoke({"q": "x", "log": ["a"]}) == {"q": "x", "log": ["a", "b"], "n": 1}
    with pytest.raises(StateTypeError):
        app.invoke({"q": "x", "n": "one"})
    drone = Drone()
    assert single(WithObject, lambda s: {"drone": drone}).invoke({})["drone"] is drone
    with pytest.raises(StateTypeError, match="'drone'"):
        single(WithObject, lambda s: {"drone": "not a drone"}).invoke({})


class Altitude(BaseModel):
    alt: float = Field(10, ge=0, le=120)
    callsign: str = "uav"

    @field_validator("callsign")
    @classmethod
    def upper(cls, v: str) -> str:
        if not v.isalnum():
            raise ValueError("callsign must be letters and digits")
        return v.upper()


def test_pydantic_field_constraints_and_validators_apply_to_updates_and_input() -> None:
    with pytest.raises(StateTypeError, match="greater than or equal to 0"):
        single(Altitude, lambda s: {"alt": -50.0}).invoke({})
    with pytest.raises(StateTypeError, match="less than or equal to 120"):
        single(Altitude, lambda s: None).invoke({"alt": 500.0})
    with pytest.raises(StateTypeError, match="letters and digits"):
        single(Altitude, lambda s: {"callsign": "uav 1"}).invoke({})
    assert single(Altitude, lambda s: {"callsign": "uav1"}).invoke({})["callsign"] == "UAV1"


def test_retry_on_accepts_a_list_and_the_default_follows_langgraph() -> None:
    attempts: list[int] = []

    def flaky(state: Paused) -> dict[str, str]:
        attempts.append(1)
        if len(attempts) < 3:
            raise TimeoutError("slow link")
        return {"note": "ok"}

    policy = RetryPolicy(initial_interval=0, jitter=False, retry_on=[ConnectionError, TimeoutError])
    g = StateGraph(Paused)
    g.add_node("flaky", flaky, retry=policy).add_edge(START, "flaky").add_edge("flaky", END)
    assert g.compile().invoke({"log": []})["note"] == "ok"
    assert default_retry_on(ConnectionError()) and default_retry_on(Exception("transient"))
    assert not any(default_retry_on(e) for e in (ValueError(), KeyError(), RuntimeError(), OSError()))
    with pytest.raises(ValueError, match="retry_on"):
        RetryPolicy(retry_on=42)  # type: ignore[arg-type]


def test_resume_without_a_checkpointer_says_what_is_missing() -> None:
    with pytest.raises(GraphError, match="needs a checkpointer"):
        single(Paused, lambda s: None).invoke(Command(resume=1))


def test_sending_a_non_state_to_a_subgraph_node_is_explained() -> None:
    class N(TypedDict, total=False):
        n: int

    sub = StateGraph(N)
    sub.add_node("inner", lambda s: None).add_edge(START, "inner").add_edge("inner", END)
    g = StateGraph(N)
    g.add_node("sub", sub.compile())
    g.add_conditional_edges(START, lambda s: [__import__("agentic_core.graph").graph.Send("sub", 5)], ["sub"])
    g.add_edge("sub", END)
    with pytest.raises(GraphError, match="subgraph node 'sub' got int 5"):
        g.compile().invoke({"n": 0})


def test_mermaid_ids_stay_unique_and_debug_is_refused() -> None:
    class N(TypedDict, total=False):
        n: int

    g = StateGraph(N)
    g.add_node("a-b", lambda s: None).add_node("a_b", lambda s: None)
    g.add_edge(START, "a-b").add_edge("a-b", "a_b").add_edge("a_b", END)
    text = g.compile().get_graph().draw_mermaid()
    assert '\ta_b("a-b")' in text and '\ta_b_2("a_b")' in text and "\ta_b --> a_b_2;" in text
    with pytest.raises(GraphError, match="debug"):
        g.compile(debug=True)
