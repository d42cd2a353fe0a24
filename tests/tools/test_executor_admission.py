"""The stages that admit a call before the tool runs: tool lookup, argument validation, and authorization by the
caller's scopes or a token."""

from typing import Any

import jwt
import pytest

from tools import Caller, MemoryAuditLog, TokenAuthority, ToolRegistry, ToolSpec

from .conftest import PILOT, SECRET, Counter, FakeClock, stage, stage_names
from .executor_fixtures import GOTO, MakeExecutor, schema_tool


# lookup -----------------------------------------------------------------------------------------------------------
def test_unknown_tool_lists_the_closest_names(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    result = make_executor(samples).call("math.ad", {"a": 1})
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("unknown tool 'math.ad'; did you mean 'math.add'")  # the closest first
    assert stage_names(result) == ["lookup:failed", "audit:passed"]
    assert result.attempts == 0 and result.tool == "math.ad"
    none_close = make_executor(samples).call("zzz.qqq", {})
    assert none_close.error == "unknown tool 'zzz.qqq'"


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


# argument validation ----------------------------------------------------------------------------------------------
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


# authorization: callers and scopes --------------------------------------------------------------------------------
def test_default_caller_and_explicit_caller(samples: ToolRegistry, make_executor: MakeExecutor) -> None:
    executor = make_executor(samples, default_caller=Caller(id="ops", scopes=frozenset({"flight:command"})))
    goto = {"target": {"lat": 1, "lon": 2}}
    assert executor.call("flight.goto", goto).caller == "ops"
    assert executor.call("flight.goto", goto).ok
    assert executor.call("flight.goto", goto, caller=Caller(id="guest")).status == "denied"


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


# authorization: tokens --------------------------------------------------------------------------------------------
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
