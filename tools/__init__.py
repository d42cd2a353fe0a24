"""Tools: the registry and guarded executor through which every agent action runs (Action + Integration layers).

>>> from tools import ToolExecutor, ToolRegistry
>>> registry = ToolRegistry()
>>> @registry.tool(name="weather.wind", scopes=["weather:read"], idempotent=True, cache_ttl_s=60)
... def wind(lat: float, lon: float) -> dict[str, float]:
...     '''Wind at a place, in m/s.'''
...     return {"speed_mps": 4.2}
>>> executor = ToolExecutor(registry, default_caller=Caller(id="pilot", scopes=frozenset({"weather:*"})))
>>> executor.call("weather.wind", {"lat": 21.42, "lon": 39.83}).output
{'speed_mps': 4.2}
>>> executor.call("weather.wind", {"lat": 21.42, "lon": 39.83}).cached
True
>>> executor.call("weather.wind", {"lat": 21.42, "lon": 39.83}, caller=Caller(id="guest")).status
'denied'
"""

from .audit import (
    AuditLog,
    AuditLogWarning,
    AuditRecord,
    JsonlAuditLog,
    MemoryAuditLog,
    SqliteAuditLog,
    open_audit_log,
    read_audit_log,
)
from .auth import ANONYMOUS, Caller, InvalidToken, TokenAuthority
from .breaker import BreakerPolicy, CircuitBreaker
from .errors import ToolDefinitionError, ToolError, TransientToolError, UnknownToolError
from .executor import ToolExecutor
from .function import tool, tool_spec
from .ratelimit import RateLimit, RateLimiter
from .registry import ToolDescription, ToolRegistry, openai_name
from .result import Stage, ToolResult, ToolStatus
from .spec import RetrySpec, ToolContext, ToolSpec, is_transient

__all__ = [
    "ANONYMOUS",
    "AuditLog",
    "AuditLogWarning",
    "AuditRecord",
    "BreakerPolicy",
    "Caller",
    "CircuitBreaker",
    "InvalidToken",
    "JsonlAuditLog",
    "MemoryAuditLog",
    "RateLimit",
    "RateLimiter",
    "RetrySpec",
    "SqliteAuditLog",
    "Stage",
    "TokenAuthority",
    "ToolContext",
    "ToolDefinitionError",
    "ToolDescription",
    "ToolError",
    "ToolExecutor",
    "ToolRegistry",
    "ToolResult",
    "ToolSpec",
    "ToolStatus",
    "TransientToolError",
    "UnknownToolError",
    "is_transient",
    "open_audit_log",
    "openai_name",
    "read_audit_log",
    "tool",
    "tool_spec",
]
