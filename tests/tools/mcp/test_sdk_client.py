"""The official SDK's client (the external peer) lists and calls our tools: over stdio, spawning our server
command, and over Streamable HTTP, with a bearer token."""

import asyncio
from typing import Any

import httpx2
import pytest
from mcp import Client, MCPError, StdioServerParameters
from mcp.client.streamable_http import streamable_http_client
from mcp.types import CallToolResult, TextContent

from tests.waiting import wait_for_async
from tools import TokenAuthority, ToolRegistry, tool
from tools.mcp import HttpHandle

from .conftest import OUR_SERVER, ROOT


def text(result: CallToolResult) -> str:
    item = result.content[0]
    assert isinstance(item, TextContent)
    return item.text


TOOLS = ["sample.add", "sample.echo", "sample.fail", "sample.slow", "sample.wind"]


def test_sdk_client_over_stdio() -> None:
    command, *args = [*OUR_SERVER, "--scopes", "weather:read"]

    async def scenario() -> None:
        async with Client(StdioServerParameters(command=command, args=args, cwd=str(ROOT))) as client:
            assert client.protocol_version == "2025-11-25"  # after its server/discover probe fell back
            assert client.server_info is not None and client.server_info.name == "agentic-uavs"
            assert [t.name for t in (await client.list_tools()).tools] == TOOLS
            added = await client.call_tool("sample.add", {"a": 2, "b": 3})
            assert text(added) == "5" and not added.is_error
            wind = await client.call_tool("sample.wind", {"lat": 21.4, "lon": 39.8})
            assert wind.structured_content == {"speed_mps": 4.2, "lat": 21.4, "lon": 39.8}
            failed = await client.call_tool("sample.fail", {"reason": "no battery"})
            assert failed.is_error and text(failed) == "error: ToolError: no battery"
            with pytest.raises(MCPError) as unknown:
                await client.call_tool("sample.nope", {})
            assert unknown.value.error.code == -32602

    asyncio.run(scenario())


def test_sdk_client_over_streamable_http(http: HttpHandle, authority: TokenAuthority, registry: ToolRegistry) -> None:
    notices: list[Any] = []

    async def on_message(message: Any) -> None:
        notices.append(message)

    async def session(subject: str, scopes: list[str]) -> tuple[Any, Any]:
        headers = {"Authorization": f"Bearer {authority.issue(subject, scopes)}"}
        async with (
            httpx2.AsyncClient(headers=headers) as http_client,
            Client(streamable_http_client(http.url, http_client=http_client), message_handler=on_message) as client,
        ):
            assert set(TOOLS) <= {t.name for t in (await client.list_tools()).tools}
            wind = await client.call_tool("sample.wind", {"lat": 1, "lon": 2})
            if subject == "pilot":  # the GET stream brings list_changed when the registry changes
                await wait_for_async(  # the SDK opens its GET stream on its own schedule
                    lambda: any(s.stream is not None for s in http._endpoint.sessions.values()),
                    5,
                    what="the client's event stream to open",
                )

                @tool(name="late.tool")
                def late() -> str:
                    return "here"

                registry.register(late)
                await wait_for_async(lambda: notices, 2, 0.02, what="a list_changed notice")
                assert text(await client.call_tool("late.tool", {})) == "here"
            return wind, client.protocol_version

    wind, version = asyncio.run(session("pilot", ["weather:read"]))
    assert version == "2025-11-25" and wind.structured_content["speed_mps"] == 4.2
    assert [getattr(n, "method", None) for n in notices] == ["notifications/tools/list_changed"]
    denied, _ = asyncio.run(session("guest", []))
    assert denied.is_error and text(denied) == "denied: 'guest' lacks scope weather:read"
    assert http.session_count == 0  # the SDK client ended its sessions with DELETE
