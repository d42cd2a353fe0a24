"""The circuit breaker: its transitions, the single half-open probe, what counts as a failure (and what does not),
and 8 threads at once."""

import threading
from typing import Any

import pytest

from tools import BreakerPolicy, ToolError, ToolRegistry, ToolResult, TransientToolError

from .conftest import Counter, FakeClock, RecordingSleep, registered, stage_names
from .executor_fixtures import BEFORE_TOOL, MakeExecutor, hammer, schema_tool


# transitions and the half-open probe ------------------------------------------------------------------------------
class Switch:
    """A tool that fails while ``failing`` is set, counting its runs."""

    def __init__(self) -> None:
        self.failing = True
        self.runs = 0

    def __call__(self, args: dict[str, Any]) -> str:
        self.runs += 1
        if self.failing:
            raise RuntimeError("backend down")
        return "up"


def test_breaker_transitions(registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor) -> None:
    tool = Switch()
    schema_tool(registry, "svc.backend", tool, breaker=BreakerPolicy(failure_threshold=2, reset_timeout_s=10))
    executor = make_executor(registry)
    breaker = registry.entry("svc.backend").breaker  # type: ignore[union-attr]

    assert executor.call("svc.backend", {}).status == "error"
    assert breaker.state == "closed" and breaker.consecutive_failures == 1
    assert executor.call("svc.backend", {}).status == "error"
    assert breaker.state == "open"  # closed -> open at the threshold

    refused = executor.call("svc.backend", {})
    assert refused.status == "circuit_open" and refused.error == "svc.backend is failing; circuit open"
    assert refused.retry_after_s == pytest.approx(10) and refused.attempts == 0 and tool.runs == 2
    assert stage_names(refused) == [*BEFORE_TOOL, "circuit_breaker:failed", "audit:passed"]
    clock.advance(4)
    assert executor.call("svc.backend", {}).retry_after_s == pytest.approx(6)

    clock.advance(6)
    assert breaker.state == "half_open"  # open -> half_open after the reset timeout
    tool.failing = False
    probe = executor.call("svc.backend", {})
    assert probe.ok and breaker.state == "closed"  # half_open -> closed on a successful probe

    tool.failing = True
    executor.call("svc.backend", {})
    executor.call("svc.backend", {})
    assert breaker.state == "open"
    clock.advance(10)
    failed_probe = executor.call("svc.backend", {})
    assert failed_probe.status == "error" and breaker.state == "open"  # half_open -> open on a failed probe
    again = executor.call("svc.backend", {})
    assert again.status == "circuit_open" and again.retry_after_s == pytest.approx(10)
    assert [state for _, state in breaker.transitions] == ["open", "closed", "open", "open"]


def test_only_one_probe_in_half_open(registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor) -> None:
    entered, release = threading.Event(), threading.Event()
    fail = [True]

    def backend(args: dict[str, Any]) -> str:
        if fail[0]:
            raise RuntimeError("down")
        entered.set()
        release.wait(5)
        return "up"

    schema_tool(registry, "svc.backend", backend, breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=5))
    executor = make_executor(registry)
    executor.call("svc.backend", {})
    clock.advance(5)
    fail[0] = False
    results: list[ToolResult] = []
    probe = threading.Thread(target=lambda: results.append(executor.call("svc.backend", {})))
    probe.start()
    try:
        assert entered.wait(5)
        second = executor.call("svc.backend", {})
        assert second.status == "circuit_open" and second.retry_after_s == 1.0  # the probe slot is taken
    finally:
        release.set()
        probe.join(5)
    assert results[0].ok
    assert executor.call("svc.backend", {}).ok  # closed again: everyone through


def test_a_probe_that_ends_without_a_verdict_frees_the_probe_slot(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    mode = ["fail"]

    @registered(registry, name="svc.backend", breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=5))
    def backend() -> dict[str, Any]:
        if mode[0] == "fail":
            raise RuntimeError("down")
        return {"handle": object()} if mode[0] == "blob" else {"state": "up"}

    executor = make_executor(registry)
    executor.call("svc.backend", {})
    clock.advance(5)
    mode[0] = "blob"
    assert executor.call("svc.backend", {}).status == "error"  # the probe ends in an error nobody counted
    mode[0] = "up"
    clock.advance(5)
    result = executor.call("svc.backend", {})
    assert result.status == "ok", result.error  # not circuit_open for ever


# what counts as a failure -----------------------------------------------------------------------------------------
def test_a_tool_error_does_not_open_the_breaker(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    def refuse(args: dict[str, Any]) -> None:
        raise ToolError("target outside the geofence")

    schema_tool(registry, "flight.goto", refuse, breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=5))
    executor = make_executor(registry)
    results = [executor.call("flight.goto", {}) for _ in range(5)]
    assert [r.status for r in results] == ["error"] * 5
    assert registry.describe("flight.goto").breaker == "closed"


def test_a_tool_error_answers_a_half_open_probe(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    errors: list[Exception] = [RuntimeError("down"), ToolError("busy with another mission")]

    def backend(args: dict[str, Any]) -> None:
        raise errors.pop(0)

    schema_tool(registry, "svc.backend", backend, breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=5))
    executor = make_executor(registry)
    executor.call("svc.backend", {})
    assert registry.describe("svc.backend").breaker == "open"
    clock.advance(5)
    assert executor.call("svc.backend", {}).error == "ToolError: busy with another mission"
    assert registry.describe("svc.backend").breaker == "closed"


def test_the_breaker_counts_one_failure_per_call_after_retries(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    def busy(args: dict[str, Any]) -> None:
        raise TransientToolError("busy")

    schema_tool(registry, "svc.busy", busy, retry=3, breaker=BreakerPolicy(failure_threshold=2))
    executor = make_executor(registry, sleep=RecordingSleep())
    result = executor.call("svc.busy", {})
    assert result.attempts == 3
    breaker = registry.entry("svc.busy").breaker  # type: ignore[union-attr]
    assert breaker.consecutive_failures == 1 and breaker.state == "closed"


def test_output_mismatch_counts_as_a_failure(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "svc.bad", lambda args: "text", output_schema={"type": "integer"}, breaker=BreakerPolicy(1))
    executor = make_executor(registry)
    assert executor.call("svc.bad", {}).status == "error"
    assert executor.call("svc.bad", {}).status == "circuit_open"


def test_a_call_whose_deadline_passed_before_the_tool_ran_is_no_tool_failure(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    ran = Counter()
    schema_tool(registry, "svc.quick", lambda args: ran.hit(), breaker=BreakerPolicy(failure_threshold=2))
    executor = make_executor(registry)
    results = [executor.call("svc.quick", {}, timeout_s=0) for _ in range(3)]
    assert [r.status for r in results] == ["timeout"] * 3
    assert ran.runs == 0
    assert registry.describe("svc.quick").breaker == "closed"  # the caller's impatience says nothing of the tool
    assert all(r.attempts == 0 for r in results)  # "times the tool itself ran"
    assert executor.call("svc.quick", {}).ok


# concurrency ------------------------------------------------------------------------------------------------------
def test_breaker_under_8_threads_lets_one_probe_through(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    fail = [True]
    release = threading.Event()
    runs = Counter()

    def backend(args: dict[str, Any]) -> str:
        runs.hit()
        if fail[0]:
            raise RuntimeError("down")
        release.wait(5)
        return "up"

    schema_tool(registry, "svc.backend", backend, breaker=BreakerPolicy(failure_threshold=3, reset_timeout_s=10))
    executor = make_executor(registry)
    statuses: list[str] = []
    lock = threading.Lock()
    done = threading.Condition(lock)

    def work(index: int) -> None:
        for _ in range(5):
            status = executor.call("svc.backend", {}).status
            with lock:
                statuses.append(status)
                done.notify_all()

    hammer(8, work)
    assert set(statuses) == {"error", "circuit_open"} and statuses.count("error") == runs.runs >= 3
    assert registry.describe("svc.backend").breaker == "open"

    clock.advance(10)
    fail[0] = False
    statuses.clear()
    runs.runs = 0

    def probe(index: int) -> None:
        status = executor.call("svc.backend", {}).status
        with lock:
            statuses.append(status)
            done.notify_all()

    threads = [threading.Thread(target=probe, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    with lock:
        done.wait_for(lambda: len(statuses) >= 7, timeout=2)
    release.set()
    for thread in threads:
        thread.join(5)
    assert sorted(statuses) == ["circuit_open"] * 7 + ["ok"] and runs.runs == 1
    assert registry.describe("svc.backend").breaker == "closed"
