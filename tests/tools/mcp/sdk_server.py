"""An MCP server written with the official SDK, the external peer of the client tests.

``python -m tests.tools.mcp.sdk_server`` serves it on stdio; :func:`app` is its Streamable HTTP app.
"""

from typing import Any

from mcp.server.mcpserver import MCPServer

server = MCPServer("sdk-sample", version="1.0", log_level="WARNING")


@server.tool()
def add(a: int, b: int) -> int:
    """Add two integers."""
    return a + b


@server.tool(name="weather/report")
def weather(city: str) -> dict[str, Any]:
    """A made-up weather report (a name with a slash, which our names do not allow)."""
    return {"city": city, "temperature_c": 21.5}


@server.tool()
def boom(reason: str) -> str:
    """Always fails."""
    raise ValueError(reason)


if __name__ == "__main__":
    server.run("stdio")
