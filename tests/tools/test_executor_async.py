"""``ToolExecutor.acall``: async tools on the caller's loop, sync tools on worker threads, timeouts, retries with the
``async_sleep`` stub, refusals and caching, and 50 concurrent calls gathered on one loop."""

import asyncio
import threading
import time
from collections.abc import Callable
from typing import Any

import pytest

from tools import BreakerPolicy, Caller, RetrySpec, ToolExecutor, ToolRegistry, ToolResult, ToolSpec, TransientToolError

from .conftest import OK_STAGES, AsyncRecordingSleep, Counter, FakeClock, RecordingSleep, registered, stage_names

pytestmark = pytest.mark.filterwarnings("ignore:The 'initial' parameter is deprecated:DeprecationWarning")
MakeExecutor = Callable[..., ToolExecutor]


def test_acall_an_async_tool_on_the_callers_loop(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    loops: list[asyncio.AbstractEventLoop] = []

    @registered(registry, name="math.add")
    async def add(a: int, b: int) -> int:
        loops.append(asyncio.get_running_loop())
        await asyncio.sleep(0)
        return a + b

    executor = make_executor(registry)

    async def main() -> tuple[ToolResult, asyncio.AbstractEventLoop]:
        return await executor.acall("math.add", {"a": 2, "b": 3}, call_id="a-1"), asyncio.get_running_loop()

    result, loop = asyncio.run(main())
    assert (result.status, result.output, result.attempts, result.call_id) == ("ok", 5, 1, "a-1")
    assert stage_names(result) == OK_STAGES
    assert loops == [loop]


def test_acall_a_sync_tool_on_a_worker_thread(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    threads: list[str] = []
    samples.register(
        ToolSpec.from_schema("svc.where", lambda args: threads.append(threading.current_thread().name), {})
    )
    executor = make_executor(samples)

    async def main() -> list[ToolResult]:
        return [await executor.acall("math.add", {"a": 1, "b": 1}), await executor.acall("svc.where", {})]

    added, where = asyncio.run(main())
    assert added.ok and added.output == 2 and stage_names(added) == OK_STAGES
    assert where.ok and threads[0].startswith("tool-sync-on-loop")  # not the loop's thread


def test_acall_refusals_match_call(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples)

    async def main() -> list[ToolResult]:
        return [
            await executor.acall("math.ad", {}),
            await executor.acall("math.add", {"a": "x", "b": 1}),
            await executor.acall("flight.goto", {"target": {"lat": 1, "lon": 1}}),
        ]

    unknown, bad, denied = asyncio.run(main())
    assert unknown.status == "error" and unknown.error is not None and unknown.error.startswith("unknown tool")
    assert bad.error == "invalid arguments: $.a: 'x' is not of type 'integer'"
    assert denied.status == "denied" and stage_names(denied)[-2:] == ["authorize:failed", "audit:passed"]


def test_acall_cache_hit(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, default_caller=Caller(id="met", scopes=frozenset({"weather:read"})))

    async def main() -> list[ToolResult]:
        return [await executor.acall("weather.wind", {"lat": 10, "lon": 20}) for _ in range(2)]

    first, second = asyncio.run(main())
    assert first.ok and not first.cached
    assert second.cached and second.attempts == 0 and second.output == first.output


def test_acall_async_tool_timeout_cancels_it(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    cancelled = []

    @registered(registry, name="svc.slow", timeout_s=0.05)
    async def slow() -> int:
        try:
            await asyncio.sleep(5)
        except asyncio.CancelledError:
            cancelled.append(True)
            raise
        return 1

    executor = make_executor(registry)
    started = time.perf_counter()
    result = asyncio.run(executor.acall("svc.slow", {}))
    assert time.perf_counter() - started < 1.0
    assert (result.status, result.error) == ("timeout", "no answer in 0.05 s") and cancelled == [True]


def test_acall_sync_tool_timeout_and_call_deadline(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    release = threading.Event()
    registry.register(ToolSpec.from_schema("svc.slow", lambda args: release.wait(5), {}, timeout_s=0.05))
    registry.register(ToolSpec.from_schema("svc.slower", lambda args: release.wait(5), {}, timeout_s=None))
    executor = make_executor(registry)

    async def main() -> list[ToolResult]:
        return [await executor.acall("svc.slow", {}), await executor.acall("svc.slower", {}, timeout_s=0.05)]

    started = time.perf_counter()
    try:
        own, deadline = asyncio.run(main())
    finally:
        release.set()
    assert time.perf_counter() - started < 1.5
    assert own.status == "timeout" and deadline.status == "timeout"


def test_acall_retries_with_async_sleep(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()

    @registered(registry, name="svc.flaky", retry=RetrySpec(attempts=4, initial_s=0.5, max_s=10, jitter_s=0))
    async def flaky() -> str:
        if runs.hit() < 3:
            raise TransientToolError("busy")
        return "done"

    async_sleep, sleep = AsyncRecordingSleep(), RecordingSleep()
    executor = make_executor(registry, async_sleep=async_sleep, sleep=sleep)
    result = asyncio.run(executor.acall("svc.flaky", {}))
    assert result.ok and result.attempts == 3 and runs.runs == 3
    assert async_sleep.delays == pytest.approx([0.5, 1.0]) and sleep.delays == []


def test_acall_retries_a_sync_tool_and_not_a_value_error(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    busy, bad = Counter(), Counter()

    def flaky(args: dict[str, Any]) -> str:
        if busy.hit() < 2:
            raise ConnectionError("reset")
        return "ok"

    def wrong(args: dict[str, Any]) -> str:
        bad.hit()
        raise ValueError("no")

    registry.register(ToolSpec.from_schema("svc.flaky", flaky, {}, retry=3))
    registry.register(ToolSpec.from_schema("svc.wrong", wrong, {}, retry=3))
    async_sleep = AsyncRecordingSleep()
    executor = make_executor(registry, async_sleep=async_sleep)

    async def main() -> list[ToolResult]:
        return [await executor.acall("svc.flaky", {}), await executor.acall("svc.wrong", {})]

    flaky_result, wrong_result = asyncio.run(main())
    assert flaky_result.ok and flaky_result.attempts == 2 and len(async_sleep.delays) == 1
    assert wrong_result.error == "ValueError: no" and wrong_result.attempts == 1 and bad.runs == 1


def test_gather_50_calls_to_an_async_and_a_sync_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    active, peak = [0], [0]

    @registered(registry, name="math.double")
    async def double(x: int) -> int:
        active[0] += 1
        peak[0] = max(peak[0], active[0])
        await asyncio.sleep(0.01)
        active[0] -= 1
        return 2 * x

    @registered(registry, name="math.triple")
    def triple(x: int) -> int:
        time.sleep(0.001)
        return 3 * x

    executor = make_executor(registry)

    async def main() -> list[ToolResult]:
        calls = [executor.acall("math.double", {"x": i}) for i in range(50)]
        calls += [executor.acall("math.triple", {"x": i}) for i in range(50)]
        return await asyncio.gather(*calls)

    started = time.perf_counter()
    results = asyncio.run(main())
    assert time.perf_counter() - started < 2.0
    assert [r.output for r in results] == [2 * i for i in range(50)] + [3 * i for i in range(50)]
    assert all(r.ok for r in results) and len({r.call_id for r in results}) == 100
    assert peak[0] > 1  # the async calls overlapped on the loop


def test_a_sync_call_from_inside_a_running_loop(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="math.neg")
    async def neg(x: int) -> int:
        return -x

    executor = make_executor(registry)

    async def main() -> ToolResult:
        return executor.call("math.neg", {"x": 4})  # blocks this loop; the tool runs on the executor's own loop

    assert asyncio.run(main()).output == -4


@pytest.mark.parametrize("timeout_s", [None, 5.0])
def test_an_async_tools_own_timeout_error(
    timeout_s: float | None, registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    @registered(registry, name="svc.upstream", timeout_s=timeout_s)
    async def upstream() -> int:
        raise TimeoutError("upstream timed out")

    executor = make_executor(registry)
    for result in (executor.call("svc.upstream", {}), asyncio.run(executor.acall("svc.upstream", {}))):
        assert result.status == "timeout", result.error
        assert result.error is not None and "upstream timed out" in result.error  # not "no answer in 5 s"


def test_a_cancelled_probe_frees_the_probe_slot(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    @registered(registry, name="svc.backend", breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=5))
    async def backend(fail: bool, wait_s: float) -> str:
        if fail:
            raise RuntimeError("down")
        await asyncio.sleep(wait_s)
        return "up"

    executor = make_executor(registry)

    async def main() -> ToolResult:
        assert (await executor.acall("svc.backend", {"fail": True, "wait_s": 0})).status == "error"
        clock.advance(5)
        with pytest.raises(TimeoutError):  # the caller gives up on the probe: its task is cancelled
            await asyncio.wait_for(executor.acall("svc.backend", {"fail": False, "wait_s": 5}), 0.05)
        clock.advance(5)
        return await executor.acall("svc.backend", {"fail": False, "wait_s": 0})

    result = asyncio.run(main())
    assert result.status == "ok", result.error  # not circuit_open for ever
