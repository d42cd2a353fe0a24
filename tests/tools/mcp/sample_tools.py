"""Tools the MCP tests serve: plain, structured, scoped, failing and slow ones."""

import asyncio

from tools import ToolError, tool


@tool(name="sample.echo")
def echo(text: str) -> str:
    """Say the text back.

    Args:
        text: what to say
    """
    return text


@tool(name="sample.add")
def add(a: int, b: int) -> int:
    """Add two integers."""
    return a + b


@tool(name="sample.wind", scopes=["weather:read"])
def wind(lat: float, lon: float) -> dict[str, float]:
    """Wind at a place, in m/s (needs the weather:read scope)."""
    return {"speed_mps": 4.2, "lat": lat, "lon": lon}


@tool(name="sample.fail")
def fail(reason: str) -> str:
    """Always fails, with the reason given."""
    raise ToolError(reason)


@tool(name="sample.slow", timeout_s=10)
async def slow(seconds: float) -> str:
    """Wait, then answer."""
    await asyncio.sleep(seconds)
    return "done"
