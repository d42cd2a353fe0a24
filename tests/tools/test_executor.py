"""The executor's status paths (ok, error, denied, rate_limited, circuit_open, timeout), retries, the result cache,
the injection guard, the stages each path records, internal errors, concurrency and the mission dispatcher."""

import asyncio
import threading
import time
import warnings
from collections.abc import Callable
from typing import Any

import jwt
import pytest

from agentic_core.mission import Environment, compile_mission, initial_state, load_mission
from tools import (
    AuditRecord,
    BreakerPolicy,
    Caller,
    MemoryAuditLog,
    RetrySpec,
    TokenAuthority,
    ToolError,
    ToolExecutor,
    ToolRegistry,
    ToolResult,
    ToolSpec,
    TransientToolError,
)

from .conftest import (
    INJECTION,
    OK_STAGES,
    PILOT,
    SECRET,
    Counter,
    FakeClock,
    RecordingSleep,
    registered,
    stage,
    stage_names,
)

# tenacity 9.2 deprecates wait_exponential_jitter(initial=...): see test_retrying_uses_no_deprecated_tenacity_api
pytestmark = pytest.mark.filterwarnings("ignore:The 'initial' parameter is deprecated:DeprecationWarning")
MakeExecutor = Callable[..., ToolExecutor]
BEFORE_TOOL = ["lookup:passed", "validate_args:passed", "authorize:passed"]
AFTER_OK = ["invoke:passed", "validate_output:passed", "injection_guard:passed", "audit:passed"]


def schema_tool(registry: ToolRegistry, name: str, handler: Callable[..., Any], **options: Any) -> None:
    schema = options.pop("input_schema", {"type": "object"})
    registry.register(ToolSpec.from_schema(name, handler, schema, **options))


# ok ---------------------------------------------------------------------------------------------------------------
def test_ok(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    result = executor.call("math.add", {"a": 2, "b": 3}, call_id="c-1")
    assert isinstance(result, ToolResult)
    assert (result.status, result.output, result.error) == ("ok", 5, None)
    assert (result.attempts, result.call_id, result.tool, result.caller) == (1, "c-1", "math.add", "anonymous")
    assert result.cached is False and result.untrusted is False and result.injection is None
    assert result.retry_after_s is None and result.latency_s >= 0
    assert stage_names(result) == OK_STAGES
    [record] = audit.records
    assert (record.call_id, record.tool, record.status, record.args) == ("c-1", "math.add", "ok", {"a": 2, "b": 3})
    assert record.stages == OK_STAGES[:-1]  # written before the audit stage itself is known


def test_every_call_gets_a_fresh_call_id(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples)
    ids = {executor.call("math.add", {"a": 1, "b": 1}).call_id for _ in range(20)}
    assert len(ids) == 20


def test_default_caller_and_explicit_caller(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, default_caller=Caller(id="ops", scopes=frozenset({"flight:command"})))
    goto = {"target": {"lat": 1, "lon": 2}}
    assert executor.call("flight.goto", goto).caller == "ops"
    assert executor.call("flight.goto", goto).ok
    assert executor.call("flight.goto", goto, caller=Caller(id="guest")).status == "denied"


# error ------------------------------------------------------------------------------------------------------------
def test_unknown_tool_lists_the_closest_names(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    result = make_executor(samples).call("math.ad", {"a": 1})
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("unknown tool 'math.ad'; did you mean 'math.add'")  # the closest first
    assert stage_names(result) == ["lookup:failed", "audit:passed"]
    assert result.attempts == 0 and result.tool == "math.ad"
    none_close = make_executor(samples).call("zzz.qqq", {})
    assert none_close.error == "unknown tool 'zzz.qqq'"


def test_bad_arguments_give_the_json_path(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, default_caller=PILOT)
    wrong_type = executor.call("math.add", {"a": "two", "b": 3})
    assert wrong_type.status == "error"
    assert wrong_type.error == "invalid arguments: $.a: 'two' is not of type 'integer'"
    assert stage_names(wrong_type) == ["lookup:passed", "validate_args:failed", "audit:passed"]
    assert stage(wrong_type, "validate_args").detail == "$.a: 'two' is not of type 'integer'"
    nested = executor.call("flight.goto", {"target": {"lat": 95, "lon": 2}})
    assert nested.error == "invalid arguments: $.target.lat: 95 is greater than the maximum of 90"
    missing = executor.call("flight.goto", {"target": {"lat": 1}})
    assert missing.error == "invalid arguments: $.target: 'lon' is a required property"
    extra = executor.call("flight.goto", {"target": {"lat": 1, "lon": 2}, "speed": 3})
    assert extra.error is not None and "Additional properties are not allowed ('speed' was unexpected)" in extra.error


def test_many_bad_arguments_are_summarised(make_executor: MakeExecutor, registry: ToolRegistry) -> None:
    schema = {"type": "object", "properties": {k: {"type": "integer"} for k in "abcde"}}
    schema_tool(registry, "svc.five", lambda args: 0, input_schema=schema)
    result = make_executor(registry).call("svc.five", {k: "x" for k in "abcde"})
    assert result.error is not None
    assert result.error.startswith("invalid arguments: $.a: 'x' is not of type 'integer'; $.b: ")
    assert result.error.endswith("(and 2 more)")


@pytest.mark.parametrize("args", [[1, 2], "a=1", 42])
def test_arguments_that_are_not_an_object(args: Any, samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    result = make_executor(samples).call("math.add", args)
    assert result.status == "error" and result.error == f"invalid arguments: expected an object, got {args!r}"
    assert stage_names(result) == ["lookup:passed", "validate_args:failed", "audit:passed"]


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


def test_output_schema_mismatch_of_a_schema_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    output_schema = {"type": "object", "properties": {"speed": {"type": "number"}}, "required": ["speed"]}
    answers: list[Any] = [{"speed": "fast"}, {"speed": 3.5}]
    schema_tool(registry, "weather.speed", lambda args: answers.pop(0), output_schema=output_schema)
    executor = make_executor(registry)
    bad = executor.call("weather.speed", {})
    assert bad.status == "error" and bad.output is None
    assert bad.error == "the tool's output does not match its schema: $.speed: 'fast' is not of type 'number'"
    assert stage_names(bad) == [
        *BEFORE_TOOL,
        "circuit_breaker:passed",
        "invoke:passed",
        "validate_output:failed",
        "audit:passed",
    ]
    good = executor.call("weather.speed", {})
    assert good.ok and good.output == {"speed": 3.5}


def test_output_schema_mismatch_of_a_function_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="weather.speeds")
    def speeds() -> list[float]:
        return [1.0, "gusty"]  # type: ignore[list-item]

    result = make_executor(registry).call("weather.speeds", {})
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("the tool's output does not match its schema: $[1]:")
    assert stage(result, "validate_output").outcome == "failed"


def test_an_unavailable_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    online = [False]
    schema_tool(registry, "camera.snap", lambda args: "jpeg", available=lambda: online[0])
    executor = make_executor(registry)
    result = executor.call("camera.snap", {})
    assert result.status == "error" and result.error == "tool 'camera.snap' is not available now"
    assert stage_names(result) == ["lookup:failed", "audit:passed"]
    assert stage(result, "lookup").detail == "unavailable"
    online[0] = True
    assert executor.call("camera.snap", {}).ok


# denied -----------------------------------------------------------------------------------------------------------
GOTO = {"target": {"lat": 21.4, "lon": 39.8}}


def test_missing_scope_is_denied(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    ran = Counter()
    samples.register(
        ToolSpec.from_schema("flight.arm", lambda args: ran.hit(), {"type": "object"}, scopes=["flight:command"])
    )
    result = make_executor(samples).call("flight.arm", {}, caller=Caller(id="guest", scopes=frozenset({"flight:read"})))
    assert result.status == "denied" and result.error == "'guest' lacks scope flight:command"
    assert stage_names(result) == ["lookup:passed", "validate_args:passed", "authorize:failed", "audit:passed"]
    assert result.attempts == 0 and ran.runs == 0


@pytest.mark.parametrize(
    ("scopes", "status"),
    [
        ({"flight:command"}, "ok"),
        ({"flight:*"}, "ok"),
        ({"*"}, "ok"),
        ({"flight:read", "weather:*"}, "denied"),
        ({"flight"}, "denied"),
        (set(), "denied"),
    ],
)
def test_scopes_and_wildcards(
    scopes: set[str], status: str, samples: ToolRegistry, make_executor: MakeExecutor
) -> None:
    result = make_executor(samples).call("flight.goto", GOTO, caller=Caller(id="c", scopes=frozenset(scopes)))
    assert result.status == status


def test_a_valid_token_names_the_caller_and_its_scopes(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    authority = TokenAuthority(SECRET)
    audit = MemoryAuditLog()
    executor = make_executor(samples, authority=authority, audit=audit)
    token = authority.issue("mission:patrol", ["flight:*"], ttl_s=60)
    result = executor.call("flight.goto", GOTO, token=token)
    assert result.ok and result.caller == "mission:patrol"
    assert audit.records[-1].caller == "mission:patrol"
    weak = authority.issue("mission:survey", ["weather:read"], ttl_s=60)
    denied = executor.call("flight.goto", GOTO, token=weak)
    assert denied.status == "denied" and denied.error == "'mission:survey' lacks scope flight:command"


def test_a_token_overrides_the_caller_argument(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    authority = TokenAuthority(SECRET)
    executor = make_executor(samples, authority=authority)
    token = authority.issue("drone-7", [], ttl_s=60)
    result = executor.call("flight.goto", GOTO, caller=PILOT, token=token)
    assert result.status == "denied" and result.caller == "drone-7"


def test_an_expired_token_is_denied(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    wall = FakeClock(1_600_000_000.0)  # wall time in the past: PyJWT checks "iat" against the real clock
    authority = TokenAuthority(SECRET, clock=wall)
    executor = make_executor(samples, authority=authority)
    token = authority.issue("mission:patrol", ["flight:*"], ttl_s=60)
    wall.advance(59.9)
    assert executor.call("flight.goto", GOTO, token=token).ok
    wall.advance(0.1)
    result = executor.call("flight.goto", GOTO, token=token)
    assert result.status == "denied" and result.error == "invalid token: it has expired"
    assert stage_names(result) == ["lookup:passed", "validate_args:passed", "authorize:failed", "audit:passed"]


@pytest.mark.parametrize(
    "token",
    [
        pytest.param(TokenAuthority("f" * 32).issue("mallory", ["*"]), id="forged"),
        pytest.param("not-a-jwt", id="garbage"),
        pytest.param("", id="empty"),
        pytest.param(TokenAuthority(SECRET, issuer="elsewhere").issue("x", ["*"]), id="other-issuer"),
        pytest.param(jwt.encode({"sub": "x", "scope": "*", "iss": "agentic-uavs"}, SECRET), id="no-expiry"),
    ],
)
def test_bad_tokens_are_denied(token: str, samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, authority=TokenAuthority(SECRET))
    result = executor.call("math.add", {"a": 1, "b": 2}, token=token)
    assert result.status == "denied" and result.error is not None and result.error.startswith("invalid token")
    assert result.output is None and result.attempts == 0


def test_a_token_without_an_authority_is_denied(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    token = TokenAuthority(SECRET).issue("x", ["*"])
    result = make_executor(samples).call("math.add", {"a": 1, "b": 2}, token=token)
    assert result.status == "denied"
    assert result.error == "a token was given, but this executor has no token authority to verify it"


# rate_limited -----------------------------------------------------------------------------------------------------
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


# circuit_open -----------------------------------------------------------------------------------------------------
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


# retries ----------------------------------------------------------------------------------------------------------
def failing(times: int, exc: Exception, counter: Counter) -> Callable[[dict[str, Any]], str]:
    def run(args: dict[str, Any]) -> str:
        if counter.hit() <= times:
            raise exc
        return "done"

    return run


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


# injection guard --------------------------------------------------------------------------------------------------
def test_instructions_in_output_are_flagged(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: {"items": [{"text": INJECTION}]})
    result = make_executor(registry).call("web.fetch", {})
    assert result.ok and result.output == {"items": [{"text": INJECTION}]}
    assert result.untrusted is True and result.injection is not None and result.injection.flagged
    assert any(f.path == "$.items[0].text" for f in result.injection.findings)
    assert stage_names(result) == [
        *BEFORE_TOOL,
        "circuit_breaker:passed",
        "invoke:passed",
        "validate_output:passed",
        "injection_guard:flagged",
        "audit:passed",
    ]
    assert stage(result, "injection_guard").detail == f"score {result.injection.score}"


def test_withheld_output(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION)
    result = make_executor(registry, on_injection="withhold").call("web.fetch", {})
    assert result.status == "error" and result.output is None
    assert result.error == "output withheld: it looks like instructions"
    assert result.injection is not None and result.untrusted
    assert stage(result, "injection_guard").outcome == "flagged"


def test_clean_and_untrusted_outputs(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: "Wind 12 kt, gusts 20.", untrusted_output=True)
    schema_tool(registry, "svc.local", lambda args: "Wind 12 kt, gusts 20.")
    executor = make_executor(registry)
    fetched = executor.call("web.fetch", {})
    assert fetched.ok and fetched.untrusted is True and fetched.injection is None
    assert stage(fetched, "injection_guard").outcome == "passed"
    local = executor.call("svc.local", {})
    assert local.untrusted is False and local.injection is None


def test_a_threshold_above_the_score_lets_it_through(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION)
    result = make_executor(registry, injection_threshold=1.0).call("web.fetch", {})
    assert result.ok and result.injection is None and stage(result, "injection_guard").outcome == "passed"


def test_a_cached_flagged_output_stays_flagged(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION, idempotent=True, cache_ttl_s=60)
    executor = make_executor(registry)
    first = executor.call("web.fetch", {"url": "https://example.org"})
    assert first.injection is not None
    again = executor.call("web.fetch", {"url": "https://example.org"})
    assert again.cached
    assert again.injection is not None and again.untrusted  # a cache hit must not launder the output


# internal errors never raise ---------------------------------------------------------------------------------------
class BrokenAudit:
    def write(self, record: AuditRecord) -> None:
        raise OSError("disk full")

    def close(self) -> None:
        pass


def test_a_failing_audit_log_still_returns_the_result(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, audit=BrokenAudit())
    result = executor.call("math.add", {"a": 1, "b": 2})
    assert result.ok and result.output == 3
    assert stage_names(result)[-1] == "audit:failed"
    assert stage(result, "audit").detail == "OSError: disk full"
    assert executor.call("nope.nope", {}).stages[-1].outcome == "failed"


def test_an_internal_error_is_a_result(
    samples: ToolRegistry, make_executor: MakeExecutor, monkeypatch: pytest.MonkeyPatch
) -> None:
    def broken_scan(value: Any, **kwargs: Any) -> Any:
        raise RuntimeError("scanner crashed")

    monkeypatch.setattr("tools.executor.scan_value", broken_scan)
    result = make_executor(samples).call("math.add", {"a": 1, "b": 2}, call_id="c-9")
    assert result.status == "error" and result.call_id == "c-9" and result.tool == "math.add"
    assert result.error == "internal error in the tool executor: RuntimeError: scanner crashed"


def test_an_output_that_cannot_be_serialised_is_an_output_error(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    @registered(registry, name="svc.blob")
    def blob() -> dict[str, Any]:
        return {"handle": object()}  # no JSON form

    audit = MemoryAuditLog()
    result = make_executor(registry, audit=audit).call("svc.blob", {})
    assert result.status == "error"
    assert stage_names(result)[-2:] == ["validate_output:failed", "audit:passed"]
    assert [r.status for r in audit.records] == ["error"]  # the audit log holds every call


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


# concurrency ------------------------------------------------------------------------------------------------------
def hammer(threads: int, work: Callable[[int], None]) -> None:
    barrier = threading.Barrier(threads)

    def run(index: int) -> None:
        barrier.wait()
        work(index)

    workers = [threading.Thread(target=run, args=(i,)) for i in range(threads)]
    for worker in workers:
        worker.start()
    for worker in workers:
        worker.join(10)


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


def test_audit_under_8_threads(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    ids: list[str] = []
    lock = threading.Lock()

    def work(index: int) -> None:
        for i in range(25):
            result = executor.call("math.add", {"a": index, "b": i})
            assert result.ok and result.output == index + i
            with lock:
                ids.append(result.call_id)

    hammer(8, work)
    assert len(ids) == 200 and sorted(ids) == sorted(r.call_id for r in audit.records)


# the mission dispatcher -------------------------------------------------------------------------------------------
def test_dispatcher_has_the_mission_runtime_signature(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples)
    dispatch = executor.dispatcher(PILOT)
    result = dispatch("math.add", {"a": 1, "b": 2}, 5.0)
    assert isinstance(result, ToolResult) and result.ok and result.output == 3 and result.caller == "pilot"
    assert dispatch("math.add", {"a": 1, "b": 2}, None).ok
    assert executor.dispatcher()("flight.goto", GOTO, None).status == "denied"  # the executor's default caller


MISSION = """
plan_id: tools-dispatch
goal: run tools through the executor
steps:
  - {id: total, action: call_tool, tool: math.add, args: {a: 2, b: 3}, timeout_s: 5}
  - {id: echoed, action: call_tool, tool: svc.echo, depends_on: [total], args: {sum: "${total}"}}
"""


def test_a_mission_runs_its_tools_through_the_dispatcher(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    audit = MemoryAuditLog()
    executor = make_executor(samples, audit=audit)
    plan = load_mission(MISSION, file="test.yaml")
    app = compile_mission(plan, Environment(dispatch=executor.dispatcher(PILOT)))
    out = app.invoke(initial_state(plan), {"recursion_limit": 100})
    assert out["status"] == {"total": "ok", "echoed": "ok"}
    assert out["outputs"]["total"] == 5
    assert out["outputs"]["echoed"] == {"sum": 5}
    assert [r.tool for r in audit.records] == ["math.add", "svc.echo"]
    assert all(r.caller == "pilot" for r in audit.records)


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
