"""Recursion limit, retry policies and node timeouts."""

import asyncio
import threading
import time
from typing import Any, TypedDict

import pytest

from agentic_core.graph import (
    END,
    START,
    GraphRecursionError,
    InMemorySaver,
    NodeTimeoutError,
    RetryPolicy,
    StateGraph,
)


class Count(TypedDict):
    count: int


def loop_graph(checkpointer: Any = None) -> Any:
    g = StateGraph(Count)
    g.add_node("inc", lambda s: {"count": s["count"] + 1})
    g.add_node("check", lambda s: None)
    g.add_edge(START, "inc")
    g.add_edge("inc", "check")
    g.add_conditional_edges("check", lambda s: END if s["count"] >= 10 else "inc", ["inc", END])
    return g.compile(checkpointer=checkpointer)


def test_recursion_limit_counts_supersteps_and_names_the_last_nodes() -> None:
    with pytest.raises(GraphRecursionError) as err:
        loop_graph().invoke({"count": 0}, {"recursion_limit": 5})
    msg = str(err.value)
    assert "recursion limit of 5 supersteps" in msg
    # the input step counts as a superstep (as in LangGraph): __start__, inc, check, inc, check
    assert "ran check and inc would run next" in msg
    assert "'recursion_limit': 50" in msg


def test_exactly_enough_supersteps_pass() -> None:
    # 20 node supersteps plus the input step
    assert loop_graph().invoke({"count": 0}, {"recursion_limit": 21}) == {"count": 10}
    with pytest.raises(GraphRecursionError):
        loop_graph().invoke({"count": 0}, {"recursion_limit": 20})


def test_a_run_stopped_by_the_limit_continues_with_a_higher_one() -> None:
    app = loop_graph(InMemorySaver())
    cfg: dict[str, Any] = {"configurable": {"thread_id": "t"}, "recursion_limit": 6}
    with pytest.raises(GraphRecursionError, match="continue it with invoke"):
        app.invoke({"count": 0}, cfg)
    assert app.get_state(cfg).values == {"count": 3}
    assert app.invoke(None, {**cfg, "recursion_limit": 100}) == {"count": 10}


def flaky_graph(
    fails: int, policy: RetryPolicy | None, exc: type[Exception] = ConnectionError
) -> tuple[Any, list[int]]:
    calls: list[int] = []

    def flaky(state: Count) -> dict[str, int]:
        calls.append(1)
        if len(calls) <= fails:
            raise exc("link down")
        return {"count": len(calls)}

    g = StateGraph(Count)
    g.add_node("flaky", flaky, retry=policy)
    g.add_edge(START, "flaky")
    g.add_edge("flaky", END)
    return g.compile(), calls


def test_retry_policy_retries_transient_failures() -> None:
    app, calls = flaky_graph(2, RetryPolicy(max_attempts=3, initial_interval=0.0, jitter=False))
    assert app.invoke({"count": 0}) == {"count": 3}
    assert len(calls) == 3


def test_retry_policy_gives_up_after_max_attempts_and_says_so() -> None:
    app, calls = flaky_graph(5, RetryPolicy(max_attempts=2, initial_interval=0.0, jitter=False))
    with pytest.raises(ConnectionError) as err:
        app.invoke({"count": 0})
    assert len(calls) == 2
    assert any("in node 'flaky'" in n and "attempt 2" in n for n in err.value.__notes__)


def test_retry_policy_does_not_retry_programming_errors_by_default() -> None:
    app, calls = flaky_graph(1, RetryPolicy(initial_interval=0.0), exc=ValueError)
    with pytest.raises(ValueError):
        app.invoke({"count": 0})
    assert len(calls) == 1


def test_retry_on_a_chosen_exception_class() -> None:
    app, calls = flaky_graph(1, RetryPolicy(initial_interval=0.0, retry_on=KeyError), exc=ConnectionError)
    with pytest.raises(ConnectionError):
        app.invoke({"count": 0})
    assert len(calls) == 1


def test_backoff_grows_exponentially_and_is_capped() -> None:
    policy = RetryPolicy(initial_interval=1.0, backoff_factor=2.0, max_interval=5.0, jitter=False)
    assert [policy.interval(a) for a in (1, 2, 3, 4)] == [1.0, 2.0, 4.0, 5.0]
    jittered = RetryPolicy(initial_interval=1.0, jitter=True).interval(1)
    assert 1.0 <= jittered <= 2.0


def test_invalid_retry_policy() -> None:
    with pytest.raises(ValueError, match="max_attempts"):
        RetryPolicy(max_attempts=0)


def test_sync_node_timeout() -> None:
    stop = threading.Event()

    def slow(state: Count) -> None:
        stop.wait(10)

    g = StateGraph(Count)
    g.add_node("slow", slow, timeout_s=0.05)
    g.add_edge(START, "slow")
    g.add_edge("slow", END)
    try:
        with pytest.raises(NodeTimeoutError, match=r"node 'slow' did not finish within timeout_s=0\.05"):
            g.compile().invoke({"count": 0})
    finally:
        stop.set()


def test_async_node_timeout_cancels_it() -> None:
    cancelled = []

    async def slow(state: Count) -> None:
        try:
            await asyncio.sleep(10)
        except asyncio.CancelledError:
            cancelled.append(True)
            raise

    g = StateGraph(Count)
    g.add_node("slow", slow, timeout_s=0.05)
    g.add_edge(START, "slow")
    g.add_edge("slow", END)
    with pytest.raises(NodeTimeoutError):
        asyncio.run(g.compile().ainvoke({"count": 0}))
    assert cancelled == [True]


def test_timeouts_can_be_retried() -> None:
    attempts: list[float] = []

    def sometimes_slow(state: Count) -> dict[str, int]:
        attempts.append(time.monotonic())
        if len(attempts) == 1:
            time.sleep(0.5)
        return {"count": len(attempts)}

    g = StateGraph(Count)
    g.add_node(
        "n", sometimes_slow, timeout_s=0.1, retry=RetryPolicy(initial_interval=0, jitter=False, retry_on=TimeoutError)
    )
    g.add_edge(START, "n")
    g.add_edge("n", END)
    assert g.compile().invoke({"count": 0}) == {"count": 2}


def test_bad_timeout() -> None:
    with pytest.raises(Exception, match="timeout_s must be positive"):
        StateGraph(Count).add_node("n", lambda s: None, timeout_s=0)
