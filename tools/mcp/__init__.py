"""MCP (Model Context Protocol): our tools served to MCP clients, and external MCP servers' tools imported as ours.

- :class:`McpServer` with :func:`serve_stdio` and :func:`serve_http` (Streamable HTTP) offers a registry's tools,
  every call through the guarded :class:`tools.ToolExecutor`;
- :class:`McpClient` talks to an external server over stdio or Streamable HTTP, and :func:`import_mcp_tools`
  registers its tools (source ``mcp``, untrusted output);
- ``python -m tools.mcp serve [--http]`` (``agentic-uav mcp serve``) runs a server: see :mod:`tools.mcp.cli`.

>>> from tools import ToolExecutor, ToolRegistry
>>> registry = ToolRegistry()
>>> @registry.tool(name="math.add")
... def add(a: int, b: int) -> int:
...     return a + b
>>> with serve_http(McpServer(ToolExecutor(registry))) as handle, McpClient.http(handle.url) as client:
...     client.call_tool("math.add", {"a": 2, "b": 3})["content"][0]["text"]
'5'
"""

from .client import McpClient, import_mcp_tools, local_name, tool_output
from .client_transports import ClientTransport, HttpTransport, McpError, SessionExpired, StdioTransport
from .http_transport import HttpHandle, serve_http
from .protocol import LATEST_VERSION, PROTOCOL_VERSIONS, JsonRpcError
from .server import McpServer, McpSession, aserve_stdio, serve_stdio

__all__ = [
    "LATEST_VERSION",
    "PROTOCOL_VERSIONS",
    "ClientTransport",
    "HttpHandle",
    "HttpTransport",
    "JsonRpcError",
    "McpClient",
    "McpError",
    "McpServer",
    "McpSession",
    "SessionExpired",
    "StdioTransport",
    "aserve_stdio",
    "import_mcp_tools",
    "local_name",
    "serve_http",
    "serve_stdio",
    "tool_output",
]
