"""Failures of the tool, of the event loop and of the executor's own life that must stay results: a tool that
exits, one that blocks the async loop, hung sync tools on the async path, cancellation, closing mid-call."""

import asyncio
import sys
import threading
import time
from typing import Any

import pytest

import tools.workers
from tests.waiting import wait_for
from tools import ToolExecutor, ToolRegistry, ToolSpec


def spec(name: str, handler: Any, **options: Any) -> ToolSpec:
    return ToolSpec.from_schema(name, handler, {"type": "object"}, **options)


def test_a_tool_that_calls_sys_exit_is_an_error_result_and_audited() -> None:
    registry = ToolRegistry()
    registry.register(spec("svc.exit", lambda args: sys.exit(3)))
    registry.register(spec("svc.exit_inline", lambda args: sys.exit(4), timeout_s=None))
    executor = ToolExecutor(registry)
    try:
        for name in ("svc.exit", "svc.exit_inline"):
            result = executor.call(name, {})
            assert result.status == "error" and result.error is not None and "SystemExit" in result.error
        assert [r.status for r in executor.audit.records] == ["error", "error"]  # type: ignore[attr-defined]
    finally:
        executor.close()


def test_a_cancelled_error_raised_by_the_tool_is_its_failure_not_a_cancellation() -> None:
    async def confused(args: dict[str, Any]) -> int:
        raise asyncio.CancelledError()

    registry = ToolRegistry()
    registry.register(spec("svc.confused", confused))
    executor = ToolExecutor(registry)
    try:
        result = asyncio.run(executor.acall("svc.confused", {}))
        assert result.status == "error" and "CancelledError" in (result.error or "")
    finally:
        executor.close()


@pytest.mark.filterwarnings("ignore:coroutine .* was never awaited")  # the quick tool, cancelled unstarted
def test_an_async_tool_that_blocks_the_loop_does_not_hold_a_sync_caller_past_its_timeout() -> None:
    blocking = threading.Event()

    async def blocker(args: dict[str, Any]) -> int:
        blocking.set()
        time.sleep(3)  # never yields: the loop is stuck for 3 s
        return 1

    async def quick(args: dict[str, Any]) -> int:
        return 2

    registry = ToolRegistry()
    registry.register(spec("svc.blocker", blocker, timeout_s=5))
    registry.register(spec("svc.quick", quick, timeout_s=0.2))
    executor = ToolExecutor(registry)
    try:
        threading.Thread(target=executor.call, args=("svc.blocker", {}), daemon=True).start()
        wait_for(blocking.is_set, 5, what="the blocking tool to start")
        started = time.perf_counter()
        result = executor.call("svc.quick", {})
        assert result.status == "timeout" and "event loop is blocked" in (result.error or "")
        assert time.perf_counter() - started < 2.5
    finally:
        executor.close()


def test_hung_sync_tools_do_not_starve_others_on_the_async_path() -> None:
    release = threading.Event()
    registry = ToolRegistry()
    registry.register(spec("svc.hang", lambda args: release.wait(10), timeout_s=0.1))
    registry.register(spec("svc.fast", lambda args: "fast", timeout_s=1))
    executor = ToolExecutor(registry)

    async def scenario() -> list[str]:
        hung = await asyncio.gather(*(executor.acall("svc.hang", {}) for _ in range(40)))
        assert {r.status for r in hung} == {"timeout"}
        fast = await executor.acall("svc.fast", {})
        return [fast.status, str(fast.output)]

    try:
        assert asyncio.run(scenario()) == ["ok", "fast"]
    finally:
        release.set()
        executor.close()


def test_closing_the_executor_mid_call_ends_the_call_and_later_calls_are_refused() -> None:
    running = threading.Event()

    async def slow(args: dict[str, Any]) -> int:
        running.set()
        await asyncio.sleep(1)
        return 1

    registry = ToolRegistry()
    registry.register(spec("svc.slow", slow, timeout_s=2))
    executor = ToolExecutor(registry)
    results: list[Any] = []
    caller = threading.Thread(target=lambda: results.append(executor.call("svc.slow", {}, timeout_s=3)))
    caller.start()
    wait_for(running.is_set, 5, what="the slow tool to start")
    executor.close()
    caller.join(5)
    assert not caller.is_alive() and results and results[0].status in ("timeout", "error")
    later = executor.call("svc.slow", {})
    assert (later.status, later.error) == ("error", "the tool executor is closed")
    assert registry.entry("svc.slow").breaker.state == "closed"  # type: ignore[union-attr]


def test_executors_created_and_closed_many_times_leave_no_threads_behind() -> None:
    async def quick(args: dict[str, Any]) -> int:
        return 1

    registry = ToolRegistry()
    registry.register(spec("svc.quick", quick))
    before = threading.active_count()
    for _ in range(20):
        executor = ToolExecutor(registry)
        assert executor.call("svc.quick", {}).ok
        executor.close()
    wait_for(lambda: threading.active_count() <= before + 2, 5, what="the executors' threads to end")


def test_a_worker_ending_on_its_idle_timer_never_loses_a_job(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(tools.workers, "IDLE_EXIT_S", 0.005)
    handoff = tools.workers.ThreadHandoff()
    try:
        for i in range(200):
            time.sleep(0.006 if i % 2 else 0.0)  # now and then just as the worker's idle wait runs out
            assert handoff.run(lambda: 1, 2.0) == 1
    finally:
        handoff.close()
