"""What a tool is: its name, schemas, guards and the handler that does the work.

Every registration path (a decorated function, an explicit JSON Schema, an HTTP endpoint description, a tool
imported from an MCP server) ends in one :class:`ToolSpec`, so one executor guards them all.
"""

from __future__ import annotations

import inspect
import json
import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import httpx
import jsonschema
from jsonschema.exceptions import SchemaError

from .auth import Caller
from .breaker import BreakerPolicy
from .errors import ToolDefinitionError, TransientToolError
from .ratelimit import RateLimit

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*(\.[A-Za-z0-9_-]+)+$")
MAX_NAME_LENGTH = 64
DEFAULT_TIMEOUT_S = 30.0

ToolSource = Literal["python", "schema", "http", "mcp"]


@dataclass(frozen=True)
class ToolContext:
    """What a running tool may know of its call. A decorated function receives it by declaring a parameter
    annotated ``ToolContext``; that parameter is not part of the tool's input schema."""

    call_id: str
    tool: str
    caller: Caller
    attempt: int
    deadline: float | None  # time.monotonic() value after which the caller stops waiting, if any
    idempotency_key: str | None = None  # the caller's name for this action, the same on a resumed run's re-run


Handler = Callable[[dict[str, Any], ToolContext], Any]
"""Runs the tool on validated arguments; returns the output, or an awaitable of it for async tools."""


def _http_transient(exc: BaseException) -> bool:
    if isinstance(exc, httpx.TransportError):
        return True
    return isinstance(exc, httpx.HTTPStatusError) and exc.response.status_code in (408, 425, 429, 500, 502, 503, 504)


def is_transient(exc: BaseException) -> bool:
    """Failures worth retrying: :class:`TransientToolError`, connection errors and timeouts, HTTP 408/425/429/5xx."""
    if isinstance(exc, TransientToolError | ConnectionError | TimeoutError):
        return True
    return _http_transient(exc)


def declared_transient(exc: BaseException) -> bool:
    """The retry test of tools that must not act twice (send a message, post a payload): only failures the tool
    itself raises as :class:`TransientToolError`, where it knows nothing went out."""
    return isinstance(exc, TransientToolError)


@dataclass(frozen=True)
class RetrySpec:
    """Up to ``attempts`` runs in all, waiting an exponentially growing, jittered delay between them
    (``initial_s``, doubling, plus up to ``jitter_s``; at most ``max_s``); only failures ``retry_if`` calls
    transient are retried, and an attempt the executor stopped waiting for is retried only for idempotent tools
    (the abandoned attempt may still act)."""

    attempts: int = 1
    initial_s: float = 0.2
    max_s: float = 5.0
    jitter_s: float = 0.2
    retry_if: Callable[[BaseException], bool] = is_transient

    def __post_init__(self) -> None:
        if self.attempts < 1:
            raise ToolDefinitionError(f"retry attempts must be at least 1 (got {self.attempts})")
        if self.initial_s < 0 or self.max_s < 0 or self.jitter_s < 0:
            raise ToolDefinitionError("retry delays must not be negative")

    @classmethod
    def of(cls, value: RetrySpec | int | None) -> RetrySpec:
        if value is None:
            return cls()
        if isinstance(value, RetrySpec):
            return value
        if isinstance(value, int) and not isinstance(value, bool):
            return cls(attempts=value)
        raise ToolDefinitionError(f"retry must be a number of attempts or a RetrySpec, not {value!r}")


_VALID_SCHEMAS: set[str] = set()
"""Schemas already checked against the metaschema (as canonical JSON): checking one costs tens of milliseconds,
and the same tools are built again and again (each run registers its flight tools)."""


def _check_schema(name: str, which: str, schema: Mapping[str, Any] | None) -> None:
    if schema is None:
        return
    try:
        key = json.dumps(schema, sort_keys=True, default=repr)
    except (TypeError, ValueError):  # not JSON at all: let the check say what is wrong
        key = None
    if key is not None and key in _VALID_SCHEMAS:
        return
    try:
        jsonschema.Draft202012Validator.check_schema(schema)
    except SchemaError as exc:
        where = "/".join(str(p) for p in exc.absolute_path) or "(root)"
        raise ToolDefinitionError(
            f"tool {name!r}: the {which} schema is not valid JSON Schema at {where}: {exc.message}"
        ) from None
    if key is not None:
        _VALID_SCHEMAS.add(key)


@dataclass(frozen=True)
class ToolSpec:
    """One tool. Build it with :func:`tools.tool` or :meth:`ToolSpec.from_schema`; register it in a
    :class:`tools.ToolRegistry`."""

    name: str
    description: str
    input_schema: Mapping[str, Any]
    handler: Handler
    output_schema: Mapping[str, Any] | None = None
    is_async: bool = False
    scopes: tuple[str, ...] = ()
    rate_limit: RateLimit | None = None
    caller_rate_limit: RateLimit | None = None
    timeout_s: float | None = DEFAULT_TIMEOUT_S
    retry: RetrySpec = field(default_factory=RetrySpec)
    cache_ttl_s: float | None = None
    idempotent: bool = False
    breaker: BreakerPolicy = field(default_factory=BreakerPolicy)
    untrusted_output: bool = False
    side_effects: bool = False  # acts outside the run (sends, writes, releases): replayed, never re-run, by key
    source: ToolSource = "schema"
    sensitive_args: frozenset[str] = frozenset()
    available: Callable[[], bool] | None = None
    convert_output: Callable[[Any], Any] | None = None  # validates and turns the handler's value into JSON data

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not NAME.match(self.name) or len(self.name) > MAX_NAME_LENGTH:
            raise ToolDefinitionError(
                f"tool name {self.name!r}: use a namespace and a name, e.g. 'weather.get_forecast' "
                f"(letters, digits, '_' or '-', at most {MAX_NAME_LENGTH} characters)"
            )
        _check_schema(self.name, "input", self.input_schema)
        if self.input_schema.get("type", "object") != "object":
            raise ToolDefinitionError(f"tool {self.name!r}: the input schema must describe an object")
        _check_schema(self.name, "output", self.output_schema)
        if self.timeout_s is not None and self.timeout_s <= 0:
            raise ToolDefinitionError(f"tool {self.name!r}: timeout_s must be positive (got {self.timeout_s})")
        if self.cache_ttl_s is not None:
            if not self.idempotent:
                raise ToolDefinitionError(f"tool {self.name!r}: only idempotent tools may cache results")
            if self.cache_ttl_s <= 0:
                raise ToolDefinitionError(f"tool {self.name!r}: cache_ttl_s must be positive")
        for scope in self.scopes:
            if not scope or " " in scope:
                raise ToolDefinitionError(f"tool {self.name!r}: bad scope {scope!r} (no spaces, not empty)")

    @property
    def namespace(self) -> str:
        return self.name.split(".", 1)[0]

    @classmethod
    def from_schema(
        cls,
        name: str,
        handler: Callable[..., Any],
        input_schema: Mapping[str, Any],
        *,
        description: str = "",
        output_schema: Mapping[str, Any] | None = None,
        **options: Any,
    ) -> ToolSpec:
        """A tool described by explicit JSON Schemas. ``handler(args)`` or ``handler(args, context)`` receives
        the validated arguments as a dict; it may be async.

        >>> spec = ToolSpec.from_schema("db.count", lambda args: len(args["rows"]),
        ...     {"type": "object", "properties": {"rows": {"type": "array"}}, "required": ["rows"]})
        >>> spec.name, spec.source
        ('db.count', 'schema')
        """
        takes_context = len(inspect.signature(handler).parameters) >= 2
        is_async = inspect.iscoroutinefunction(handler) or (
            not inspect.isfunction(handler) and inspect.iscoroutinefunction(type(handler).__call__)  # async __call__
        )
        call: Handler = handler if takes_context else (lambda args, _context: handler(args))
        return cls(
            name=name,
            description=description,
            input_schema=dict(input_schema),
            output_schema=None if output_schema is None else dict(output_schema),
            handler=call,
            is_async=is_async,
            source=options.pop("source", "schema"),
            **spec_options(name, **options),
        )


def spec_options(
    name: str,
    *,
    scopes: Iterable[str] = (),
    rate_limit: str | RateLimit | None = None,
    caller_rate_limit: str | RateLimit | None = None,
    burst: float | None = None,
    caller_burst: float | None = None,
    timeout_s: float | None = DEFAULT_TIMEOUT_S,
    retry: RetrySpec | int | None = None,
    cache_ttl_s: float | None = None,
    idempotent: bool = False,
    breaker: BreakerPolicy | None = None,
    untrusted_output: bool = False,
    side_effects: bool = False,
    sensitive_args: tuple[str, ...] | list[str] | frozenset[str] = (),
    available: Callable[[], bool] | None = None,
) -> dict[str, Any]:
    """The keyword options every registration path accepts, turned into :class:`ToolSpec` fields."""
    if isinstance(scopes, str):  # a lone string would be read as its letters
        raise ToolDefinitionError(f"tool {name!r}: scopes must be a list, e.g. scopes=[{scopes!r}]")
    if not isinstance(side_effects, bool):
        raise ToolDefinitionError(f"tool {name!r}: side_effects must be True or False, not {side_effects!r}")

    def limit(value: str | RateLimit | None, size: float | None, which: str) -> RateLimit | None:
        if value is not None and not isinstance(value, str | RateLimit):
            raise ToolDefinitionError(f"tool {name!r}: {which} must be a string such as '10/s', not {value!r}")
        if size is not None and not isinstance(value, str):
            given = "a RateLimit object (it carries its own burst)" if value is not None else "no limit"
            raise ToolDefinitionError(f"tool {name!r}: {which} burst given with {given}")
        try:
            return RateLimit.parse(value, size) if isinstance(value, str) else value
        except ToolDefinitionError as exc:
            raise ToolDefinitionError(f"tool {name!r}: {exc}") from None

    return {
        "scopes": tuple(scopes),
        "rate_limit": limit(rate_limit, burst, "rate_limit"),
        "caller_rate_limit": limit(caller_rate_limit, caller_burst, "caller_rate_limit"),
        "timeout_s": timeout_s,
        "retry": RetrySpec.of(retry),
        "cache_ttl_s": cache_ttl_s,
        "idempotent": idempotent,
        "breaker": breaker or BreakerPolicy(),
        "untrusted_output": untrusted_output,
        "side_effects": side_effects,
        "sensitive_args": frozenset(sensitive_args),
        "available": available,
    }
