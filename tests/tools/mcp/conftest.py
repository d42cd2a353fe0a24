"""Shared fixtures of the MCP tests: the sample tools, our server in-process, the SDK's server on a free port."""

import asyncio
import socket
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.waiting import wait_for
from tools import Caller, TokenAuthority, ToolExecutor, ToolRegistry
from tools.mcp import HttpHandle, McpServer, McpSession, serve_http

from . import sample_tools

ROOT = Path(__file__).resolve().parents[3]
SECRET = "test-secret-" + "x" * 32
PILOT = Caller(id="pilot", scopes=frozenset({"weather:read"}))

OUR_SERVER = [sys.executable, "-m", "tools.mcp", "serve", "--no-builtins", "--tools", "tests.tools.mcp.sample_tools"]
SDK_SERVER = [sys.executable, "-m", "tests.tools.mcp.sdk_server"]


@pytest.fixture
def registry() -> ToolRegistry:
    registry = ToolRegistry()
    registry.register_module(sample_tools)
    return registry


@pytest.fixture
def executor(registry: ToolRegistry) -> Iterator[ToolExecutor]:
    executor = ToolExecutor(registry)
    yield executor
    executor.close()


@pytest.fixture
def server(executor: ToolExecutor) -> McpServer:
    return McpServer(executor)


@pytest.fixture
def authority() -> TokenAuthority:
    return TokenAuthority(SECRET)


@pytest.fixture
def http(server: McpServer, authority: TokenAuthority) -> Iterator[HttpHandle]:
    with serve_http(server, "127.0.0.1", 0, authority) as handle:
        yield handle


def rpc(server: McpServer, session: McpSession, message: Any) -> Any:
    return asyncio.run(server.handle(message, session))


def call(id: Any, method: str, params: dict[str, Any] | None = None) -> dict[str, Any]:
    message: dict[str, Any] = {"jsonrpc": "2.0", "id": id, "method": method}
    if params is not None:
        message["params"] = params
    return message


def initialize(server: McpServer, session: McpSession, version: str = "2025-11-25") -> dict[str, Any]:
    params = {"protocolVersion": version, "capabilities": {}, "clientInfo": {"name": "test", "version": "1"}}
    reply = rpc(server, session, call(1, "initialize", params))
    rpc(server, session, {"jsonrpc": "2.0", "method": "notifications/initialized"})
    return dict(reply["result"])


@pytest.fixture
def sdk_http_url() -> Iterator[str]:
    """The SDK's Streamable HTTP server (SSE answers) under uvicorn on a free loopback port, in a thread."""
    import uvicorn

    from .sdk_server import server as sdk

    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen()
    config = uvicorn.Config(sdk.streamable_http_app(), log_level="warning", lifespan="on")
    runner = uvicorn.Server(config)
    thread = threading.Thread(target=runner.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    wait_for(lambda: runner.started, 10, what="the SDK server to start")
    try:
        yield f"http://127.0.0.1:{sock.getsockname()[1]}/mcp"
    finally:
        runner.should_exit = True
        thread.join(timeout=10)
        sock.close()
