"""Our Streamable HTTP transport, request by request with httpx: sessions, versions, tokens, origins, the GET
stream."""

import json
import socket
import threading
from collections.abc import Iterator

import httpx
import pytest

from tests.waiting import wait_for
from tools import TokenAuthority, ToolRegistry, tool
from tools.mcp import HttpHandle, McpServer, serve_http

from .conftest import call

INIT = call(1, "initialize", {"protocolVersion": "2025-06-18", "capabilities": {}, "clientInfo": {"name": "t"}})
ACCEPT = {"Accept": "application/json, text/event-stream"}


@pytest.fixture
def token(authority: TokenAuthority) -> str:
    return authority.issue("pilot", ["weather:read"])


@pytest.fixture
def client(http: HttpHandle, token: str) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=http.url, headers={**ACCEPT, "Authorization": f"Bearer {token}"}, timeout=10) as c:
        yield c


def open_session(client: httpx.Client) -> dict[str, str]:
    response = client.post("", json=INIT)
    assert response.status_code == 200 and response.headers["content-type"] == "application/json"
    assert response.json()["result"]["protocolVersion"] == "2025-06-18"
    headers = {"Mcp-Session-Id": response.headers["mcp-session-id"], "MCP-Protocol-Version": "2025-06-18"}
    assert (
        client.post("", json={"jsonrpc": "2.0", "method": "notifications/initialized"}, headers=headers).status_code
        == 202
    )
    return headers


def test_a_session_id_is_issued_at_initialize(client: httpx.Client, http: HttpHandle) -> None:
    headers = open_session(client)
    session_id = headers["Mcp-Session-Id"]
    assert len(session_id) >= 24 and all(0x21 <= ord(c) <= 0x7E for c in session_id)
    reply = client.post("", json=call(0, "ping"), headers=headers)
    assert reply.status_code == 200 and reply.json() == {"jsonrpc": "2.0", "id": 0, "result": {}}
    assert http.session_count == 1


def test_later_requests_need_the_session(client: httpx.Client) -> None:
    headers = open_session(client)
    assert client.post("", json=call(2, "tools/list")).status_code == 400
    unknown = client.post("", json=call(2, "tools/list"), headers={**headers, "Mcp-Session-Id": "nope"})
    assert unknown.status_code == 404
    assert client.post("", json=call(2, "tools/list"), headers=headers).status_code == 200


def test_another_callers_session_is_not_found(client: httpx.Client, authority: TokenAuthority) -> None:
    headers = open_session(client)
    other = {"Authorization": f"Bearer {authority.issue('intruder', ['*'])}"}
    assert client.post("", json=call(2, "tools/list"), headers={**headers, **other}).status_code == 404


def test_the_protocol_version_header_is_checked(client: httpx.Client) -> None:
    headers = open_session(client)
    for bad in ("2099-01-01", "2025-11-25", "garbage"):
        response = client.post("", json=call(2, "ping"), headers={**headers, "MCP-Protocol-Version": bad})
        assert response.status_code == 400, bad
    without = {"Mcp-Session-Id": headers["Mcp-Session-Id"]}  # absent: the negotiated version holds
    assert client.post("", json=call(3, "ping"), headers=without).status_code == 200


def test_delete_ends_the_session(client: httpx.Client, http: HttpHandle) -> None:
    headers = open_session(client)
    assert client.delete("", headers=headers).status_code == 204
    assert client.post("", json=call(2, "ping"), headers=headers).status_code == 404
    assert client.delete("", headers=headers).status_code == 404
    assert http.session_count == 0


def test_notifications_and_responses_are_accepted_with_202(client: httpx.Client) -> None:
    headers = open_session(client)
    for message in ({"jsonrpc": "2.0", "method": "notifications/whatever"}, {"jsonrpc": "2.0", "id": 9, "result": {}}):
        response = client.post("", json=message, headers=headers)
        assert response.status_code == 202 and response.content == b""


def test_json_rpc_errors_over_http(client: httpx.Client) -> None:
    headers = open_session(client)
    unknown = client.post("", json=call(2, "no/such"), headers=headers)
    assert unknown.status_code == 200 and unknown.json()["error"]["code"] == -32601
    parse = client.post("", content=b"{not json", headers={**headers, "Content-Type": "application/json"})
    assert parse.status_code == 400 and parse.json()["error"]["code"] == -32700
    batch = client.post("", json=[call(3, "ping"), call(4, "ping")], headers=headers)
    assert batch.status_code == 400 and batch.json()["error"]["code"] == -32600
    text = client.post("", content=b"{}", headers={**headers, "Content-Type": "text/plain"})
    assert text.status_code == 415


def test_tools_and_scopes_come_from_the_token(client: httpx.Client, authority: TokenAuthority) -> None:
    headers = open_session(client)
    args = {"name": "sample.wind", "arguments": {"lat": 1, "lon": 2}}
    ok = client.post("", json=call(2, "tools/call", args), headers=headers).json()["result"]
    assert ok["structuredContent"]["speed_mps"] == 4.2
    guest = {"Authorization": f"Bearer {authority.issue('guest', [])}"}
    guest_session = open_session(httpx.Client(base_url=client.base_url, headers={**ACCEPT, **guest}))
    denied = client.post("", json=call(3, "tools/call", args), headers={**guest_session, **guest}).json()["result"]
    assert denied["isError"] is True and denied["content"][0]["text"].startswith("denied: 'guest' lacks scope")


def test_a_missing_or_bad_token_is_401(http: HttpHandle, authority: TokenAuthority) -> None:
    missing = httpx.post(http.url, json=INIT, headers=ACCEPT)
    assert missing.status_code == 401 and missing.headers["www-authenticate"].startswith("Bearer")
    forged = TokenAuthority("another-secret-" + "y" * 32).issue("pilot", ["*"])
    bad = httpx.post(http.url, json=INIT, headers={**ACCEPT, "Authorization": f"Bearer {forged}"})
    assert bad.status_code == 401 and 'error="invalid_token"' in bad.headers["www-authenticate"]
    expired = TokenAuthority(authority._key, clock=lambda: 0.0).issue("pilot", ["*"], ttl_s=1)
    assert httpx.post(http.url, json=INIT, headers={**ACCEPT, "Authorization": f"Bearer {expired}"}).status_code == 401


@pytest.mark.parametrize(
    ("origin", "status"),
    [("http://evil.example", 403), ("null", 403), ("http://localhost:3000", 200), ("http://127.0.0.1", 200)],
)
def test_the_origin_is_checked(client: httpx.Client, origin: str, status: int) -> None:
    assert client.post("", json=INIT, headers={"Origin": origin}).status_code == status


def test_a_foreign_host_header_is_refused_on_loopback(client: httpx.Client) -> None:
    assert client.post("", json=INIT, headers={"Host": "rebound.example:80"}).status_code == 421


def test_other_paths_and_methods(client: httpx.Client, http: HttpHandle) -> None:
    assert client.post(http.url.replace("/mcp", "/other"), json=INIT).status_code == 404
    response = client.put("", json=INIT)
    assert response.status_code == 405 and response.headers["allow"] == "GET, POST, DELETE"


def test_the_get_stream_carries_list_changed(client: httpx.Client, registry: ToolRegistry) -> None:
    headers = open_session(client)
    assert client.get("", headers={"Accept": "text/event-stream"}).status_code == 400  # no session
    with client.stream("GET", "", headers={**headers, "Accept": "text/event-stream"}) as stream:
        assert stream.status_code == 200 and stream.headers["content-type"] == "text/event-stream"
        second = client.get("", headers={**headers, "Accept": "text/event-stream"})
        assert second.status_code == 409  # one stream per session: a message goes on one stream only

        @tool(name="late.tool")
        def late() -> str:
            return "here"

        registry.register(late)
        lines = stream.iter_lines()
        assert next(lines) == "event: message"
        assert json.loads(next(lines).removeprefix("data: ")) == {
            "jsonrpc": "2.0",
            "method": "notifications/tools/list_changed",
        }


def test_close_ends_open_streams(server: McpServer) -> None:
    handle = serve_http(server, "127.0.0.1", 0)  # loopback without an authority: the default caller
    with httpx.Client(base_url=handle.url, headers=ACCEPT, timeout=10) as client:
        headers = open_session(client)
        ended = threading.Event()

        def listen() -> None:
            with client.stream("GET", "", headers={**headers, "Accept": "text/event-stream"}) as stream:
                for _ in stream.iter_lines():
                    pass
            ended.set()

        thread = threading.Thread(target=listen)
        thread.start()
        session = handle._endpoint.sessions[headers["Mcp-Session-Id"]]
        wait_for(lambda: session.stream is not None, 5, what="the session's event stream to open")
        handle.close()
        assert ended.wait(5)
        thread.join(5)


def test_only_loopback_without_a_token_authority(server: McpServer, authority: TokenAuthority) -> None:
    with pytest.raises(ValueError, match="AGENTIC_UAV_TOKEN_SECRET"):
        serve_http(server, "0.0.0.0", 0)
    with pytest.raises(ValueError, match="without a token authority"):
        serve_http(server, "192.0.2.1", 0)
    with serve_http(server, "::1", 0) if _has_ipv6() else serve_http(server, "localhost", 0) as handle:
        assert httpx.post(handle.url, json=INIT, headers=ACCEPT).status_code == 200


def _has_ipv6() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as sock:
            sock.bind(("::1", 0))
        return True
    except OSError:
        return False


def test_a_caller_flooding_sessions_ends_only_its_own_oldest(
    client: httpx.Client, authority: TokenAuthority, monkeypatch: pytest.MonkeyPatch
) -> None:
    import tools.mcp.http_transport as transport

    monkeypatch.setattr(transport, "MAX_SESSIONS_PER_CALLER", 3)
    monkeypatch.setattr(transport, "MAX_SESSIONS", 5)
    admin = {"Authorization": f"Bearer {authority.issue('admin', ['*'])}"}
    admin_session = {**admin, **open_session_as(client, admin)}
    flood = [open_session(client) for _ in range(10)]  # the pilot's token opens ten; it may keep three
    assert client.post("", json=call(2, "tools/list"), headers=flood[0]).status_code == 404  # its oldest ended
    assert client.post("", json=call(3, "tools/list"), headers=flood[-1]).status_code == 200
    assert client.post("", json=call(4, "tools/list"), headers=admin_session).status_code == 200  # untouched


def open_session_as(client: httpx.Client, auth: dict[str, str]) -> dict[str, str]:
    response = client.post("", json=INIT, headers=auth)
    assert response.status_code == 200
    return {"Mcp-Session-Id": response.headers["mcp-session-id"], "MCP-Protocol-Version": "2025-06-18"}
