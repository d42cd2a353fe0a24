"""Rate limits (per tool and per caller) and the result cache, call by call and under 8 concurrent threads."""

import threading
import time
from typing import Any

import pytest

from tools import BreakerPolicy, Caller, ToolRegistry

from .conftest import PILOT, Counter, FakeClock, registered, stage, stage_names
from .executor_fixtures import BEFORE_TOOL, MakeExecutor, failing, hammer, schema_tool

AFTER_OK = ["invoke:passed", "validate_output:passed", "injection_guard:passed", "audit:passed"]


# rate limits ------------------------------------------------------------------------------------------------------
def test_rate_limited_with_retry_after(registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "svc.ping", lambda args: "pong", rate_limit="2/s")
    executor = make_executor(registry)
    first, second, third = (executor.call("svc.ping", {}) for _ in range(3))
    assert first.ok and second.ok
    assert stage_names(first) == [*BEFORE_TOOL, "rate_limit:passed", "circuit_breaker:passed", *AFTER_OK]
    assert third.status == "rate_limited" and third.error == "rate limit reached for svc.ping"
    assert third.retry_after_s == pytest.approx(0.5)
    assert stage_names(third) == [*BEFORE_TOOL, "rate_limit:failed", "audit:passed"]
    assert stage(third, "rate_limit").detail == "retry in 0.5 s"
    clock.advance(0.25)
    assert executor.call("svc.ping", {}).retry_after_s == pytest.approx(0.25)
    clock.advance(0.25)
    assert executor.call("svc.ping", {}).ok


def test_refused_calls_use_no_rate_tokens(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "flight.arm", lambda args: True, rate_limit="1/min", scopes=["flight:command"])
    executor = make_executor(registry)
    for _ in range(3):
        assert executor.call("flight.arm", {}).status == "denied"  # authorization comes before the limiter
        assert executor.call("flight.arm", []).status == "error"  # type: ignore[arg-type]
    assert executor.call("flight.arm", {}, caller=PILOT).ok
    assert executor.call("flight.arm", {}, caller=PILOT).status == "rate_limited"


def test_per_caller_limits_are_independent(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "svc.ping", lambda args: "pong", caller_rate_limit="1/s")
    executor = make_executor(registry)
    alice, bob = Caller(id="alice"), Caller(id="bob")
    assert executor.call("svc.ping", {}, caller=alice).ok
    assert executor.call("svc.ping", {}, caller=alice).status == "rate_limited"
    assert executor.call("svc.ping", {}, caller=bob).ok
    assert executor.call("svc.ping", {}, caller=bob).status == "rate_limited"


# cache ------------------------------------------------------------------------------------------------------------
def cached_tool(registry: ToolRegistry, runs: Counter, **options: Any) -> None:
    @registered(registry, name="weather.wind", idempotent=True, cache_ttl_s=60, **options)
    def wind(lat: float, lon: float) -> dict[str, Any]:
        return {"speed_mps": 4.2, "run": runs.hit()}


def test_cache_hit_on_equal_arguments(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    cached_tool(registry, runs)
    executor = make_executor(registry)
    first = executor.call("weather.wind", {"lat": 21.4, "lon": 39.8})
    assert first.ok and not first.cached and first.attempts == 1
    assert stage_names(first) == [*BEFORE_TOOL, "cache:miss", "circuit_breaker:passed", *AFTER_OK]
    hit = executor.call("weather.wind", {"lon": 39.8, "lat": 21.4})  # another key order
    assert hit.ok and hit.cached and hit.attempts == 0 and hit.output == first.output and runs.runs == 1
    assert stage_names(hit) == [*BEFORE_TOOL, "cache:hit", "audit:passed"]
    other = executor.call("weather.wind", {"lat": 21.5, "lon": 39.8})
    assert not other.cached and runs.runs == 2


def test_cache_ttl_expiry(registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor) -> None:
    runs = Counter()
    cached_tool(registry, runs)
    executor = make_executor(registry)
    args = {"lat": 1.0, "lon": 2.0}
    executor.call("weather.wind", args)
    clock.advance(59.9)
    assert executor.call("weather.wind", args).cached
    clock.advance(0.1)
    expired = executor.call("weather.wind", args)
    assert not expired.cached and expired.output["run"] == 2
    assert executor.call("weather.wind", args).cached


def test_failures_are_not_cached(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    schema_tool(
        registry,
        "svc.flaky",
        failing(1, RuntimeError("down"), runs),
        idempotent=True,
        cache_ttl_s=60,
    )
    executor = make_executor(registry)
    assert executor.call("svc.flaky", {}).status == "error"
    second = executor.call("svc.flaky", {})
    assert second.ok and not second.cached and runs.runs == 2
    assert executor.call("svc.flaky", {}).cached


def test_a_cache_hit_still_needs_authorization(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    cached_tool(registry, runs, scopes=["weather:read"])
    executor = make_executor(registry)
    args = {"lat": 1.0, "lon": 2.0}
    assert executor.call("weather.wind", args, caller=PILOT).ok
    denied = executor.call("weather.wind", args)
    assert denied.status == "denied" and denied.output is None and not denied.cached


def test_a_cached_answer_is_served_while_the_breaker_is_open(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    def wind(args: dict[str, Any]) -> float:
        if args["lat"] > 80:
            raise RuntimeError("no data near the pole")
        return 4.2

    schema_tool(registry, "weather.wind", wind, idempotent=True, cache_ttl_s=60, breaker=BreakerPolicy(1))
    executor = make_executor(registry)
    assert executor.call("weather.wind", {"lat": 10}).ok
    assert executor.call("weather.wind", {"lat": 85}).status == "error"
    assert registry.describe("weather.wind").breaker == "open"
    served = executor.call("weather.wind", {"lat": 10})
    assert served.ok and served.cached and served.output == 4.2
    assert executor.call("weather.wind", {"lat": 11}).status == "circuit_open"


def test_a_cached_output_is_not_changed_by_a_caller(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()
    cached_tool(registry, runs)
    executor = make_executor(registry)
    args = {"lat": 1.0, "lon": 2.0}
    first = executor.call("weather.wind", args)
    first.output["speed_mps"] = 99.0  # the caller edits its copy of the answer
    assert executor.call("weather.wind", args).output == {"speed_mps": 4.2, "run": 1}


# concurrency ------------------------------------------------------------------------------------------------------
def test_limiter_admission_under_8_concurrent_callers_real_time(make_executor: MakeExecutor) -> None:
    registry = ToolRegistry()  # the real monotonic clock
    started = time.monotonic()
    schema_tool(registry, "svc.ping", lambda args: "pong", rate_limit="20/s", burst=5)
    executor = make_executor(registry)
    statuses: list[str] = []
    lock = threading.Lock()

    def work(index: int) -> None:
        end = started + 0.5
        while time.monotonic() < end:
            status = executor.call("svc.ping", {}, caller=Caller(id=f"c{index}")).status
            with lock:
                statuses.append(status)
            time.sleep(0.001)

    hammer(8, work)
    elapsed = time.monotonic() - started
    admitted = statuses.count("ok")
    assert set(statuses) == {"ok", "rate_limited"}
    assert 5 <= admitted <= 20 * elapsed + 5


def test_limiter_admission_under_8_concurrent_callers_fake_clock(
    registry: ToolRegistry, clock: FakeClock, make_executor: MakeExecutor
) -> None:
    schema_tool(registry, "svc.ping", lambda args: "pong", rate_limit="20/s", burst=5, timeout_s=None)
    executor = make_executor(registry)
    admitted = Counter()
    stop = threading.Event()

    def work(index: int) -> None:
        while not stop.is_set():
            if executor.call("svc.ping", {}).ok:
                admitted.hit()
            time.sleep(0.0002)  # let the clock thread in

    def advance() -> None:
        for _ in range(50):
            time.sleep(0.002)
            clock.advance(0.01)
        stop.set()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    advance()
    for thread in threads:
        thread.join(5)
    assert 5 <= admitted.runs <= 20 * 0.5 + 5


def test_per_caller_limits_under_8_threads(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "svc.ping", lambda args: "pong", caller_rate_limit="3/s", timeout_s=None)
    executor = make_executor(registry)
    admitted: dict[str, int] = {}
    lock = threading.Lock()

    def work(index: int) -> None:
        caller = Caller(id=f"drone-{index}")
        ok = sum(executor.call("svc.ping", {}, caller=caller).ok for _ in range(10))
        with lock:
            admitted[caller.id] = ok

    hammer(8, work)  # the fake clock stands still: each caller gets exactly its burst
    assert admitted == {f"drone-{i}": 3 for i in range(8)}


def test_cache_under_8_threads(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    runs = Counter()

    @registered(registry, name="math.square", idempotent=True, cache_ttl_s=60)
    def square(x: int) -> int:
        runs.hit()
        return x * x

    executor = make_executor(registry)
    wrong: list[tuple[int, Any]] = []
    cached = Counter()

    def work(index: int) -> None:
        for i in range(40):
            x = (i + index) % 5
            result = executor.call("math.square", {"x": x})
            if not result.ok or result.output != x * x:
                wrong.append((x, result.output))
            if result.cached:
                cached.hit()

    hammer(8, work)
    assert wrong == []
    assert runs.runs + cached.runs == 320
    assert 5 <= runs.runs <= 5 * 8  # at most one concurrent miss per thread and key
    entry = registry.entry("math.square")
    assert entry is not None and entry.cache is not None and len(entry.cache) == 5
