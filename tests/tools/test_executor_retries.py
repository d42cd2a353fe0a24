"""Running the tool: failures, retries with backoff, per-tool timeouts and the call's own deadline."""

import asyncio
import threading
import time
import warnings
from typing import Any

import pytest

from tools import RetrySpec, ToolError, ToolRegistry, TransientToolError

from .conftest import Counter, FakeClock, RecordingSleep, registered, stage, stage_names
from .executor_fixtures import BEFORE_TOOL, MakeExecutor, failing, schema_tool

# tenacity 9.2 deprecates wait_exponential_jitter(initial=...): see test_retrying_uses_no_deprecated_tenacity_api
pytestmark = pytest.mark.filterwarnings("ignore:The 'initial' parameter is deprecated:DeprecationWarning")


# failures ---------------------------------------------------------------------------------------------------------
def test_a_tool_that_raises(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    def boom(args: dict[str, Any]) -> None:
        raise ValueError("boom")

    schema_tool(registry, "svc.boom", boom)
    result = make_executor(registry).call("svc.boom", {})
    assert (result.status, result.error, result.attempts) == ("error", "ValueError: boom", 1)
    assert stage_names(result) == [*BEFORE_TOOL, "circuit_breaker:passed", "invoke:failed", "audit:passed"]
    assert stage(result, "invoke").detail == "1 attempt"


def test_a_tool_error_is_shown_as_is(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    def refuse(args: dict[str, Any]) -> None:
        raise ToolError("no fuel left")

    schema_tool(registry, "svc.refuse", refuse, retry=3)
    result = make_executor(registry).call("svc.refuse", {})
    assert (result.status, result.error, result.attempts) == ("error", "ToolError: no fuel left", 1)  # never retried


# timeout ----------------------------------------------------------------------------------------------------------
def test_a_sync_tool_past_its_timeout(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    release = threading.Event()
    schema_tool(registry, "svc.slow", lambda args: release.wait(5), timeout_s=0.1)
    executor = make_executor(registry)
    started = time.perf_counter()
    try:
        result = executor.call("svc.slow", {})
    finally:
        release.set()
    assert time.perf_counter() - started < 1.0
    assert (result.status, result.error, result.attempts) == ("timeout", "no answer in 0.1 s", 1)
    assert stage_names(result) == [*BEFORE_TOOL, "circuit_breaker:passed", "invoke:failed", "audit:passed"]
    assert executor.call("svc.slow", {}).ok  # the calling thread got a fresh worker


def test_the_calls_own_deadline(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    release = threading.Event()
    schema_tool(registry, "svc.slow", lambda args: release.wait(5), timeout_s=None)
    executor = make_executor(registry)
    started = time.perf_counter()
    try:
        result = executor.call("svc.slow", {}, timeout_s=0.1)
    finally:
        release.set()
    assert time.perf_counter() - started < 1.0
    assert result.status == "timeout"


def test_an_async_tool_timeout_cancels_the_coroutine(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    cancelled = threading.Event()

    @registered(registry, name="svc.slow_async", timeout_s=0.1)
    async def slow() -> int:
        try:
            await asyncio.sleep(5)
        except asyncio.CancelledError:
            cancelled.set()
            raise
        return 1

    started = time.perf_counter()
    result = make_executor(registry).call("svc.slow_async", {})
    assert time.perf_counter() - started < 1.0
    assert (result.status, result.error) == ("timeout", "no answer in 0.1 s")
    assert cancelled.wait(1)


def test_timeouts_of_idempotent_tools_are_retried(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    release = threading.Event()
    calls = Counter()

    def slow_then_fast(args: dict[str, Any]) -> str:
        if calls.hit() == 1:
            release.wait(5)
        return "done"

    schema_tool(registry, "svc.slow", slow_then_fast, timeout_s=0.05, retry=2, idempotent=True)
    sleep = RecordingSleep()
    try:
        result = make_executor(registry, sleep=sleep).call("svc.slow", {})
    finally:
        release.set()
    assert result.ok and result.attempts == 2 and len(sleep.delays) == 1


def test_an_attempt_that_timed_out_is_not_retried_for_a_tool_that_acts(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    done: list[str] = []
    finished = threading.Event()

    def page(args: dict[str, Any]) -> str:
        time.sleep(0.3)
        done.append(args["text"])
        finished.set()
        return "sent"

    schema_tool(registry, "alerts.page", page, retry=3, timeout_s=0.1)
    result = make_executor(registry, sleep=lambda s: None).call("alerts.page", {"text": "hi"})
    assert (result.status, result.attempts) == ("timeout", 1)
    assert finished.wait(2)
    time.sleep(0.4)  # a second attempt, had one started, would have finished by now
    assert done == ["hi"]


def test_an_idempotent_tool_is_retried_after_a_timed_out_attempt(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    calls: list[int] = []

    def lookup(args: dict[str, Any]) -> int:
        calls.append(1)
        if len(calls) == 1:
            time.sleep(0.3)
        return len(calls)

    schema_tool(registry, "svc.lookup", lookup, retry=3, timeout_s=0.1, idempotent=True)
    result = make_executor(registry, sleep=lambda s: None).call("svc.lookup", {})
    assert (result.status, result.attempts, result.output) == ("ok", 2, 2)


# retries ----------------------------------------------------------------------------------------------------------
def test_transient_failures_are_retried_with_growing_delays(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    runs = Counter()
    retry = RetrySpec(attempts=4, initial_s=0.1, max_s=10, jitter_s=0)
    schema_tool(registry, "svc.flaky", failing(2, TransientToolError("busy"), runs), retry=retry)
    sleep = RecordingSleep()
    result = make_executor(registry, sleep=sleep).call("svc.flaky", {})
    assert result.ok and result.output == "done" and result.attempts == 3 and runs.runs == 3
    assert sleep.delays == pytest.approx([0.1, 0.2])
    assert stage(result, "invoke").detail == "3 attempts"


def test_retries_give_up_after_the_attempts(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    retry = RetrySpec(attempts=4, initial_s=0.1, max_s=0.3, jitter_s=0.05)
    schema_tool(registry, "svc.down", failing(99, ConnectionError("refused"), runs), retry=retry)
    sleep = RecordingSleep()
    result = make_executor(registry, sleep=sleep).call("svc.down", {})
    assert (result.status, result.error, result.attempts, runs.runs) == ("error", "ConnectionError: refused", 4, 4)
    assert stage(result, "invoke").detail == "4 attempts"
    assert len(sleep.delays) == 3
    assert 0.1 <= sleep.delays[0] <= 0.15 and 0.2 <= sleep.delays[1] <= 0.25
    assert sleep.delays[2] == pytest.approx(0.3)  # capped at max_s
    assert sleep.delays[0] < sleep.delays[1] < sleep.delays[2] + 1e-9


@pytest.mark.parametrize("exc", [ValueError("bad value"), ToolError("refused"), KeyError("k")])
def test_non_transient_failures_are_not_retried(
    exc: Exception, registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    runs = Counter()
    schema_tool(registry, "svc.flaky", failing(1, exc, runs), retry=5)
    sleep = RecordingSleep()
    result = make_executor(registry, sleep=sleep).call("svc.flaky", {})
    assert result.status == "error" and result.attempts == 1 and runs.runs == 1 and sleep.delays == []


def test_a_custom_retry_if(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    retry = RetrySpec(attempts=3, initial_s=1, jitter_s=0, retry_if=lambda e: isinstance(e, KeyError))
    key_runs, busy_runs = Counter(), Counter()
    schema_tool(registry, "svc.keys", failing(2, KeyError("later"), key_runs), retry=retry)
    schema_tool(registry, "svc.busy", failing(2, TransientToolError("busy"), busy_runs), retry=retry)
    executor = make_executor(registry, sleep=RecordingSleep())
    assert executor.call("svc.keys", {}).attempts == 3 and key_runs.runs == 3
    busy = executor.call("svc.busy", {})
    assert busy.status == "error" and busy.attempts == 1 and busy_runs.runs == 1


def test_retrying_uses_no_deprecated_tenacity_api(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    schema_tool(registry, "svc.flaky", failing(1, TransientToolError("busy"), runs), retry=RetrySpec(attempts=2))
    executor = make_executor(registry, sleep=RecordingSleep())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert executor.call("svc.flaky", {}).ok
    assert [str(w.message) for w in caught if issubclass(w.category, DeprecationWarning)] == []


def test_the_calls_deadline_stops_retries(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    runs = Counter()
    retry = RetrySpec(attempts=5, initial_s=1, max_s=10, jitter_s=0)
    schema_tool(registry, "svc.flaky", failing(99, TransientToolError("busy"), runs), retry=retry)
    sleep = RecordingSleep(clock)
    result = make_executor(registry, clock=clock, sleep=sleep).call("svc.flaky", {}, timeout_s=2.5)
    # t=0 fails, wait 1 -> t=1 fails, a wait of 2 would end past the deadline: stop
    assert result.status == "error" and result.attempts == 2 and sleep.delays == [1]
