"""Attacks on MCP over HTTP from another local process, with real requests to a server on 127.0.0.1: no anonymous
physical or sending power, sessions that belong to their caller, and forged tokens audited as what they claim."""

import asyncio
import base64
import json
import subprocess
from collections.abc import Iterator
from typing import Any

import httpx
import httpx2
import jwt
import pytest
from mcp import Client
from mcp.client.streamable_http import streamable_http_client

from agentic_core.contracts.errors import InputError
from flight.tools import register_flight_tools
from flight.vehicle import FlightResult, Telemetry
from tools import Caller, MemoryAuditLog, TokenAuthority, ToolExecutor, ToolRegistry
from tools.auth import MAX_CLAIMED_CHARS
from tools.mcp import HttpHandle, McpServer, serve_http
from tools.mcp.cli import main

from .conftest import OUR_SERVER, ROOT, SECRET, call

INIT = call(1, "initialize", {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "t"}})
ACCEPT = {"Accept": "application/json, text/event-stream"}
LAND = call(2, "tools/call", {"name": "flight.land", "arguments": {}})
RELEASE = call(3, "tools/call", {"name": "flight.deploy_payload", "arguments": {"payload": "rescue_kit"}})
OPERATOR = Caller(id="local:operator", scopes=frozenset({"flight:*", "alerts:*"}))


class Drone:
    """The flight tools' client, in-process: it records every action the tools send it."""

    def __init__(self) -> None:
        self.actions: list[str] = []
        self.telemetry = Telemetry(connected=True, armed=True, mode="hold")

    def __getattr__(self, name: str) -> Any:
        async def act(*args: Any, **kwargs: Any) -> FlightResult:
            self.actions.append(name)
            return FlightResult(action=name, status="ok", elapsed_s=0.0, state=self.telemetry)

        return act


@pytest.fixture
def drone() -> Drone:
    return Drone()


@pytest.fixture
def audit() -> MemoryAuditLog:
    return MemoryAuditLog()


@pytest.fixture
def flight_server(drone: Drone, audit: MemoryAuditLog) -> Iterator[McpServer]:
    async def connect() -> Any:
        return drone

    registry = ToolRegistry()
    register_flight_tools(registry, connect)
    executor = ToolExecutor(registry, audit=audit, default_caller=OPERATOR)
    yield McpServer(executor)
    executor.close()


@pytest.fixture
def guarded(flight_server: McpServer, authority: TokenAuthority) -> Iterator[HttpHandle]:
    with serve_http(flight_server, "127.0.0.1", 0, authority) as handle:
        yield handle


def session_headers(url: str, auth: dict[str, str]) -> dict[str, str]:
    response = httpx.post(url, json=INIT, headers={**ACCEPT, **auth})
    assert response.status_code == 200, response.text
    return {
        **ACCEPT,
        **auth,
        "Mcp-Session-Id": response.headers["mcp-session-id"],
        "MCP-Protocol-Version": "2025-06-18",
    }


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


# no anonymous physical or sending power ---------------------------------------------------------------------------
@pytest.mark.parametrize("scopes", [{"flight:*"}, {"flight:command"}, {"flight:payload"}, {"alerts:*"}, {"*"}])
def test_without_a_token_physical_and_sending_scopes_are_refused_at_start(
    flight_server: McpServer, scopes: set[str]
) -> None:
    caller = Caller(id="local:operator", scopes=frozenset({"weather:read", *scopes}))
    with pytest.raises(InputError, match="AGENTIC_UAV_TOKEN_SECRET") as refused:
        serve_http(flight_server, "127.0.0.1", 0, caller=caller)
    assert sorted(scopes)[0] in str(refused.value)
    with pytest.raises(InputError):  # the executor's default caller, the operator, holds flight:* too
        serve_http(flight_server, "127.0.0.1", 0)


def test_two_unauthenticated_requests_cannot_land_or_release(
    flight_server: McpServer, drone: Drone, guarded: HttpHandle, authority: TokenAuthority
) -> None:
    """The finding: initialize, then tools/call, from any local process. With no token: start-up refused (above);
    with tokens: both requests are 401, whatever token they forge, and the drone never hears a thing."""
    for attempt in ({}, bearer("garbage"), bearer(TokenAuthority("z" * 32).issue("local:operator", ["*"]))):
        assert httpx.post(guarded.url, json=INIT, headers={**ACCEPT, **attempt}).status_code == 401
        for action in (LAND, RELEASE):
            reply = httpx.post(guarded.url, json=action, headers={**ACCEPT, **attempt, "Mcp-Session-Id": "x"})
            assert reply.status_code == 401
    operator = session_headers(guarded.url, bearer(authority.issue("operator", ["flight:read"])))
    denied = httpx.post(guarded.url, json=LAND, headers=operator).json()["result"]  # a token without the scope
    assert denied["isError"] and "lacks scope flight:command" in denied["content"][0]["text"]
    assert drone.actions == []


def test_without_a_token_other_scopes_are_served_and_flight_calls_are_denied(drone: Drone, audit: Any) -> None:
    async def connect() -> Any:
        return drone

    registry = ToolRegistry()
    register_flight_tools(registry, connect)
    with (
        ToolExecutor(
            registry, audit=audit, default_caller=Caller(id="local:me", scopes=frozenset({"weather:read"}))
        ) as ex,
        serve_http(McpServer(ex), "127.0.0.1", 0) as handle,
    ):
        headers = session_headers(handle.url, {})
        for action in (LAND, RELEASE):
            result = httpx.post(handle.url, json=action, headers=headers).json()["result"]
            assert result["isError"] and "lacks scope flight:" in result["content"][0]["text"]
    assert drone.actions == []


def test_the_cli_refuses_flight_scopes_without_a_token() -> None:
    env = {"PATH": "/usr/bin:/bin"}  # no AGENTIC_UAV_TOKEN_SECRET
    for scopes in (["flight:*"], ["alerts:send_email", "weather:read"]):
        done = subprocess.run(
            [*OUR_SERVER, "--http", "--port", "0", "--scopes", *scopes],
            cwd=ROOT,
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert done.returncode == 2, done.stderr
        assert "Traceback" not in done.stderr and "AGENTIC_UAV_TOKEN_SECRET" in done.stderr
        assert "agentic-uav mcp token" in done.stderr and scopes[0] in done.stderr


def test_the_token_command_signs_with_the_secret(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], authority: TokenAuthority
) -> None:
    monkeypatch.delenv("AGENTIC_UAV_TOKEN_SECRET", raising=False)
    assert main(["token", "operator", "--scopes", "flight:*"]) == 2
    assert "AGENTIC_UAV_TOKEN_SECRET" in capsys.readouterr().err
    monkeypatch.setenv("AGENTIC_UAV_TOKEN_SECRET", SECRET)
    assert main(["token", "operator", "--scopes", "flight:*,alerts:*", "--ttl", "60"]) == 0
    caller = authority.verify(capsys.readouterr().out.strip())
    assert caller.id == "operator" and caller.scopes == frozenset({"flight:*", "alerts:*"})
    assert main(["token", "operator", "--ttl", "0"]) == 2 and "positive" in capsys.readouterr().err


def test_the_sdk_client_flies_with_a_token(guarded: HttpHandle, authority: TokenAuthority, drone: Drone) -> None:
    async def scenario() -> tuple[bool, bool]:
        headers = bearer(authority.issue("operator", ["flight:*"]))
        async with (
            httpx2.AsyncClient(headers=headers) as http_client,
            Client(streamable_http_client(guarded.url, http_client=http_client)) as client,
        ):
            landed = await client.call_tool("flight.land", {})
            released = await client.call_tool("flight.deploy_payload", {"payload": "rescue_kit"})
            return landed.is_error, released.is_error

    assert asyncio.run(scenario()) == (False, False)
    assert drone.actions == ["land", "deploy_payload"]


# sessions belong to their caller ----------------------------------------------------------------------------------
def test_another_caller_can_neither_use_nor_end_a_session(guarded: HttpHandle, authority: TokenAuthority) -> None:
    operator = session_headers(guarded.url, bearer(authority.issue("operator", ["flight:read"])))
    stolen = {**operator, **bearer(authority.issue("intruder", ["*"]))}
    assert httpx.delete(guarded.url, headers=stolen).status_code == 404
    assert httpx.get(guarded.url, headers={**stolen, "Accept": "text/event-stream"}).status_code == 404
    assert httpx.post(guarded.url, json=LAND, headers=stolen).status_code == 404
    assert httpx.post(guarded.url, json=call(9, "ping"), headers=operator).status_code == 200
    assert guarded.session_count == 1


def test_a_flood_near_the_server_cap_evicts_only_the_flooders_sessions(
    guarded: HttpHandle, authority: TokenAuthority, monkeypatch: pytest.MonkeyPatch
) -> None:
    import tools.mcp.http_transport as transport

    monkeypatch.setattr(transport, "MAX_SESSIONS_PER_CALLER", 3)
    monkeypatch.setattr(transport, "MAX_SESSIONS", 4)
    victims = [session_headers(guarded.url, bearer(authority.issue(f"crew-{n}", []))) for n in range(3)]
    flooder = bearer(authority.issue("flooder", []))
    first = session_headers(guarded.url, flooder)  # the server is now full
    for _ in range(5):  # each new one takes the place of the flooder's own oldest
        session_headers(guarded.url, flooder)
    assert httpx.post(guarded.url, json=call(5, "ping"), headers=first).status_code == 404
    newcomer = httpx.post(guarded.url, json=INIT, headers={**ACCEPT, **bearer(authority.issue("newcomer", []))})
    assert newcomer.status_code == 503 and newcomer.headers["retry-after"]  # nobody else's session to take
    for victim in victims:
        assert httpx.post(guarded.url, json=call(6, "ping"), headers=victim).status_code == 200
    assert guarded.session_count == 4


def test_without_a_token_a_flood_cannot_end_existing_sessions(
    server: McpServer, monkeypatch: pytest.MonkeyPatch
) -> None:
    import tools.mcp.http_transport as transport

    monkeypatch.setattr(transport, "MAX_SESSIONS_PER_CALLER", 3)
    with serve_http(server, "127.0.0.1", 0) as handle:
        operator = session_headers(handle.url, {})
        flood = [httpx.post(handle.url, json=INIT, headers=ACCEPT).status_code for _ in range(6)]
        assert flood == [200, 200, 503, 503, 503, 503]  # every local process is one caller: refused, not evicted
        assert httpx.post(handle.url, json=call(7, "ping"), headers=operator).status_code == 200


# audit: a forged token is recorded as what it claims -------------------------------------------------------------
def test_a_forged_token_over_http_is_audited_as_unverified(
    guarded: HttpHandle, audit: MemoryAuditLog, drone: Drone
) -> None:
    forged = TokenAuthority("z" * 32).issue("local:operator", ["*"])
    batch = [LAND, RELEASE, call(4, "ping")]
    for body in (LAND, batch):
        assert httpx.post(guarded.url, json=body, headers={**ACCEPT, **bearer(forged)}).status_code == 401
    records = audit.records
    assert [(r.caller, r.tool, r.status) for r in records] == [
        ("unverified: local:operator", "flight.land", "denied"),
        ("unverified: local:operator", "flight.land", "denied"),
        ("unverified: local:operator", "flight.deploy_payload", "denied"),
    ]
    assert all(r.error and "Signature verification failed" in r.error and r.attempts == 0 for r in records)
    assert OPERATOR.id not in {r.caller for r in records} and drone.actions == []


def test_a_claimed_subject_is_bounded_and_sanitised(guarded: HttpHandle, audit: MemoryAuditLog) -> None:
    hostile = "admin\n\x1b[2K\u202eok" + "A" * 1_000
    forged = jwt.encode({"sub": hostile, "iss": "agentic-uavs", "exp": 2**40}, "z" * 32)
    no_subject = jwt.encode({"iss": "agentic-uavs", "exp": 2**40}, "z" * 32)
    header = base64.urlsafe_b64encode(b'{"alg":"none"}').rstrip(b"=").decode()
    nested = base64.urlsafe_b64encode(json.dumps({"sub": {"sub": "x"}}).encode()).rstrip(b"=").decode()
    for token in (forged, no_subject, "eyJ.!!!.x", f"{header}.{nested}.", "x" * 20_000):
        assert httpx.post(guarded.url, json=LAND, headers={**ACCEPT, **bearer(token)}).status_code == 401
    callers = [r.caller for r in audit.records]
    assert callers[1:] == ["unverified: ?"] * 4
    shown = callers[0].removeprefix("unverified: ")
    assert shown.startswith("admin [2K ok") and len(shown) == MAX_CLAIMED_CHARS
    assert all(ch.isprintable() for ch in callers[0])


def test_refused_arguments_are_redacted_and_bounded(guarded: HttpHandle, audit: MemoryAuditLog) -> None:
    forged = TokenAuthority("z" * 32).issue("mallory", ["*"])
    secret = {"name": "flight.land", "arguments": {"password": "hunter22", "note": "x"}}
    huge = {"name": "flight.land", "arguments": {"note": "y" * 100_000}}
    many = [call(n, "tools/call", secret) for n in range(100)]
    for body in (call(1, "tools/call", secret), call(2, "tools/call", huge), many):
        assert httpx.post(guarded.url, json=body, headers={**ACCEPT, **bearer(forged)}).status_code == 401
    first, second, *rest = audit.records
    assert first.args == {"password": "[redacted]", "note": "x"}
    assert list(second.args) == ["[omitted]"] and len(json.dumps(second.args)) < 100
    assert len(rest) == 16  # a body's calls recorded up to a bound, not a flood of records


def test_the_executor_records_a_bad_token_as_unverified() -> None:
    registry = ToolRegistry()

    @registry.tool(name="math.add")
    def add(a: int, b: int) -> int:
        return a + b

    audit = MemoryAuditLog()
    default = Caller(id="local:operator", scopes=frozenset({"*"}))
    forged = TokenAuthority("z" * 32).issue("local:operator", ["*"])
    with ToolExecutor(registry, audit=audit, authority=TokenAuthority(SECRET), default_caller=default) as ex:
        result = ex.call("math.add", {"a": 1, "b": 2}, token=forged)
        garbage = ex.call("math.add", {"a": 1, "b": 2}, token="not-a-jwt")
    with ToolExecutor(registry, audit=audit, default_caller=default) as no_authority:
        unverifiable = no_authority.call("math.add", {"a": 1, "b": 2}, token=forged)
    assert (result.status, result.caller, result.output) == ("denied", "unverified: local:operator", None)
    assert [r.caller for r in audit.records] == [
        "unverified: local:operator",
        "unverified: ?",
        "unverified: local:operator",
    ]
    assert garbage.status == unverifiable.status == "denied"
