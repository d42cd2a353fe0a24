"""The tool registry: register and unregister at run time, look up, list, describe and export the catalogue.

Each registered tool gets its own guards (rate limiter, circuit breaker, result cache), shared by every executor
that uses the registry: a breaker is a fact about the tool, not about one caller.
"""

from __future__ import annotations

import difflib
import hashlib
import threading
import time
from collections.abc import Callable, Container, Iterator, Mapping
from dataclasses import dataclass
from typing import Any, TypeVar, overload

import jsonschema
from pydantic import BaseModel, ConfigDict

from .breaker import BreakerState, CircuitBreaker
from .cache import ResultCache
from .errors import ToolDefinitionError, UnknownToolError
from .fastcheck import flat_checker
from .function import is_tool, spec_from_function, tool_spec
from .ratelimit import RateLimiter
from .spec import ToolSpec

F = TypeVar("F", bound=Callable[..., Any])


@dataclass
class RegisteredTool:
    """A tool with its compiled argument validator, its guards and its name in OpenAI's format."""

    spec: ToolSpec
    openai_name: str
    validator: jsonschema.protocols.Validator
    output_validator: jsonschema.protocols.Validator | None
    limiter: RateLimiter | None
    breaker: CircuitBreaker
    cache: ResultCache | None
    quick_check: Callable[[Mapping[str, Any]], bool] | None = None  # a fast "valid" for flat schemas


class ToolDescription(BaseModel):
    """What ``tools list`` and ``describe`` show of a tool."""

    model_config = ConfigDict(frozen=True)

    name: str
    description: str
    input_schema: dict[str, Any]
    output_schema: dict[str, Any] | None
    scopes: list[str]
    rate_limit: str | None
    caller_rate_limit: str | None
    timeout_s: float | None
    retry_attempts: int
    idempotent: bool
    side_effects: bool  # acts outside the run: replayed by idempotency key, never run twice
    cache_ttl_s: float | None
    source: str
    breaker: BreakerState
    available: bool


OPENAI_NAME_LIMIT = 64


def openai_name(name: str, taken: Container[str] = ()) -> str:
    """OpenAI function names allow only letters, digits, ``_`` and ``-``, at most 64: ``weather.get_forecast`` is
    exported as ``weather__get_forecast``. A name that would be too long or is ``taken`` gets a short hash of the
    real name at its end, so every tool keeps a name of its own; :meth:`ToolRegistry.resolve` maps it back."""
    alias = name.replace(".", "__")
    if len(alias) <= OPENAI_NAME_LIMIT and alias not in taken:
        return alias
    digest = hashlib.sha1(name.encode()).hexdigest()[:8]
    return f"{alias[: OPENAI_NAME_LIMIT - 9]}_{digest}"


class ToolRegistry:
    """Tools by name.

    >>> from tools import tool
    >>> registry = ToolRegistry()
    >>> @registry.tool(name="math.add")
    ... def add(a: int, b: int) -> int:
    ...     '''Add two numbers.'''
    ...     return a + b
    >>> registry.names(), registry.closest("math.ad")
    (['math.add'], ['math.add'])
    >>> registry.to_openai()[0]["function"]["name"]
    'math__add'
    """

    def __init__(self, *, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._tools: dict[str, RegisteredTool] = {}
        self._by_openai_name: dict[str, str] = {}
        self._lock = threading.Lock()
        self._listeners: list[Callable[[], None]] = []

    # registration -------------------------------------------------------------------------------------------------
    def register(self, item: ToolSpec | Callable[..., Any], *, replace: bool = False) -> ToolSpec:
        """Register a :class:`ToolSpec` or a function decorated with ``@tool``; a name taken is an error unless
        ``replace`` (the replaced tool's guards start afresh)."""
        spec = item if isinstance(item, ToolSpec) else tool_spec(item)
        with self._lock:
            if spec.name in self._tools and not replace:
                raise ToolDefinitionError(f"tool {spec.name!r} is already registered (pass replace=True to replace it)")
            old = self._tools.get(spec.name)
            aliases = {k: v for k, v in self._by_openai_name.items() if old is None or k != old.openai_name}
            entry = self._entry(spec, openai_name(spec.name, aliases))
            aliases[entry.openai_name] = spec.name
            tools = dict(self._tools)
            tools[spec.name] = entry
            self._tools, self._by_openai_name = tools, aliases  # readers see old or new dicts, never one changing
        self._changed()
        return spec

    @overload
    def tool(self, fn: F, /) -> F: ...
    @overload
    def tool(self, /, **options: Any) -> Callable[[F], F]: ...
    def tool(self, fn: Any = None, /, **options: Any) -> Any:
        """``@registry.tool(name=..., ...)``: define a tool (as :func:`tools.tool`) and register it."""

        def decorate(function: F) -> F:
            if not is_tool(function) or options:
                from .function import SPEC_ATTRIBUTE

                setattr(function, SPEC_ATTRIBUTE, spec_from_function(function, **options))
            self.register(function)
            return function

        return decorate(fn) if fn is not None else decorate

    def register_module(self, module: Any, *, replace: bool = False) -> list[str]:
        """Register every ``@tool`` function a module defines; returns their names."""
        names = []
        for value in vars(module).values():
            if is_tool(value):
                names.append(self.register(value, replace=replace).name)
        return names

    def unregister(self, name: str) -> ToolSpec:
        with self._lock:
            if name not in self._tools:
                raise UnknownToolError(name, self.closest(name))
            tools = dict(self._tools)
            entry = tools.pop(name)
            aliases = {k: v for k, v in self._by_openai_name.items() if v != name}
            self._tools, self._by_openai_name = tools, aliases
        self._changed()
        return entry.spec

    def subscribe(self, listener: Callable[[], None]) -> Callable[[], None]:
        """Call ``listener()`` after each change (the MCP server tells its clients); returns an unsubscribe."""
        self._listeners.append(listener)

        def unsubscribe() -> None:
            if listener in self._listeners:  # calling it twice is harmless
                self._listeners.remove(listener)

        return unsubscribe

    def _changed(self) -> None:
        for listener in list(self._listeners):
            listener()

    def _entry(self, spec: ToolSpec, alias: str) -> RegisteredTool:
        checker = jsonschema.FormatChecker()
        validator = jsonschema.Draft202012Validator(spec.input_schema, format_checker=checker)
        output_validator = None
        if spec.output_schema is not None and spec.convert_output is None:
            output_validator = jsonschema.Draft202012Validator(spec.output_schema, format_checker=checker)
        limiter = None
        if spec.rate_limit is not None or spec.caller_rate_limit is not None:
            limiter = RateLimiter(spec.rate_limit, spec.caller_rate_limit, clock=self.clock)
        cache = ResultCache(spec.cache_ttl_s, clock=self.clock) if spec.cache_ttl_s is not None else None
        breaker = CircuitBreaker(spec.breaker, clock=self.clock)
        return RegisteredTool(
            spec, alias, validator, output_validator, limiter, breaker, cache, flat_checker(spec.input_schema)
        )

    # lookup -------------------------------------------------------------------------------------------------------
    def entry(self, name: str) -> RegisteredTool | None:
        return self._tools.get(name)

    def get(self, name: str) -> ToolSpec:
        entry = self._tools.get(name) or self._tools.get(self.resolve(name))
        if entry is None:
            raise UnknownToolError(name, self.closest(name))
        return entry.spec

    def input_schema(self, name: str) -> Mapping[str, Any]:
        return self.get(name).input_schema

    def resolve(self, name: str) -> str:
        """A registered name for ``name`` or its OpenAI spelling (``weather__get_forecast``); else ``name``."""
        if name in self._tools:
            return name
        return self._by_openai_name.get(name, name)

    def closest(self, name: str, n: int = 3) -> list[str]:
        return difflib.get_close_matches(name, list(self._tools), n=n, cutoff=0.6)

    def __contains__(self, name: object) -> bool:
        return name in self._tools

    def __iter__(self) -> Iterator[ToolSpec]:
        return iter([entry.spec for entry in self._tools.values()])

    def __len__(self) -> int:
        return len(self._tools)

    def names(self, namespace: str | None = None) -> list[str]:
        return sorted(n for n in self._tools if namespace is None or n.split(".", 1)[0] == namespace)

    # catalogue ----------------------------------------------------------------------------------------------------
    def describe(self, name: str) -> ToolDescription:
        """A tool's metadata and state; ``name`` may be its OpenAI spelling."""
        entry = self._tools.get(self.resolve(name))
        if entry is None:
            raise UnknownToolError(name, self.closest(name))
        spec = entry.spec
        return ToolDescription(
            name=spec.name,
            description=spec.description,
            input_schema=dict(spec.input_schema),
            output_schema=None if spec.output_schema is None else dict(spec.output_schema),
            scopes=list(spec.scopes),
            rate_limit=spec.rate_limit.text if spec.rate_limit else None,
            caller_rate_limit=spec.caller_rate_limit.text if spec.caller_rate_limit else None,
            timeout_s=spec.timeout_s,
            retry_attempts=spec.retry.attempts,
            idempotent=spec.idempotent,
            side_effects=spec.side_effects,
            cache_ttl_s=spec.cache_ttl_s,
            source=spec.source,
            breaker=entry.breaker.state,
            available=is_available(spec),
        )

    def catalogue(self) -> list[ToolDescription]:
        return [self.describe(name) for name in self.names()]

    def to_openai(self) -> list[dict[str, Any]]:
        """The catalogue in OpenAI's tool-calling format (``tools=[...]`` of chat completions)."""
        return [
            {
                "type": "function",
                "function": {
                    "name": entry.openai_name,
                    "description": entry.spec.description or entry.spec.name,
                    "parameters": dict(entry.spec.input_schema),
                },
            }
            for entry in sorted(self._tools.values(), key=lambda e: e.spec.name)
        ]

    def to_mcp(self) -> list[dict[str, Any]]:
        """The catalogue as MCP ``tools/list`` entries (``name``, ``description``, ``inputSchema``, ...)."""
        return [mcp_tool(spec) for spec in sorted(self, key=lambda s: s.name)]


def mcp_tool(spec: ToolSpec) -> dict[str, Any]:
    """One tool as MCP describes it; annotations tell clients whether it only reads and may be retried."""
    entry: dict[str, Any] = {
        "name": spec.name,
        "description": spec.description or spec.name,
        "inputSchema": dict(spec.input_schema),
        "annotations": {"idempotentHint": spec.idempotent, "openWorldHint": spec.source in ("http", "mcp")},
    }
    if spec.output_schema is not None and spec.output_schema.get("type") == "object":
        entry["outputSchema"] = dict(spec.output_schema)  # MCP allows only object output schemas
    return entry


def is_available(spec: ToolSpec) -> bool:
    if spec.available is None:
        return True
    try:
        return bool(spec.available())
    except Exception:
        return False
