"""Tools from typed Python functions: the ``@tool`` decorator.

The input schema comes from the parameters' type hints (through pydantic) and the docstring's description of each
parameter (Google ``Args:``, NumPy ``Parameters`` or Sphinx ``:param x:`` style); the output schema from the return
annotation. The function stays a plain function: calling it directly runs no guard.
"""

from __future__ import annotations

import inspect
import re
import typing
from collections.abc import Callable
from typing import Any, TypeVar, get_origin, overload

from pydantic import ConfigDict, Field, TypeAdapter, ValidationError, create_model
from pydantic.fields import FieldInfo

from .errors import ToolDefinitionError, ToolError
from .spec import ToolContext, ToolSpec, spec_options

F = TypeVar("F", bound=Callable[..., Any])
SPEC_ATTRIBUTE = "__agentic_tool__"

_SECTION = re.compile(
    r"^\s*(Args|Arguments|Parameters|Params|Returns?|Yields?|Raises|Examples?|Notes?|See Also)\s*:?\s*$", re.I
)
_GOOGLE_PARAM = re.compile(r"^\s*\*{0,2}(\w+)\s*(?:\([^)]*\))?\s*:\s*(.*)$")
_SPHINX_PARAM = re.compile(r"^\s*:param\s+(?:[^:]*\s)?(\w+)\s*:\s*(.*)$")
_NUMPY_PARAM = re.compile(r"^(\w+)\s+:(?:\s*[^:]*)?$")  # "lat : float": a space before the colon


def parse_docstring(doc: str | None) -> tuple[str, dict[str, str]]:
    """A docstring's description (text before its first section) and a description per parameter."""
    lines = inspect.cleandoc(doc or "").splitlines()
    description: list[str] = []
    params: dict[str, str] = {}
    section: str | None = None
    current: str | None = None
    for line in lines:
        header = _SECTION.match(line)
        if header and not line.startswith(" "):
            section, current = header.group(1).lower(), None
            continue
        if set(line.strip()) <= {"-"} and line.strip():
            continue  # NumPy underline
        sphinx = _SPHINX_PARAM.match(line)
        if sphinx:
            current, section = sphinx.group(1), "params"
            params[current] = sphinx.group(2).strip()
            continue
        if line.strip().startswith(":"):
            current, section = None, "other"
            continue
        if section is None:
            description.append(line)
        elif section in ("args", "arguments", "parameters", "params"):
            google = _GOOGLE_PARAM.match(line)
            numpy = _NUMPY_PARAM.match(line)
            indent = len(line) - len(line.lstrip())
            if numpy:
                current = numpy.group(1)
                params[current] = ""
            elif google and indent <= 4 and google.group(2):
                current = google.group(1)
                params[current] = google.group(2).strip()
            elif current and line.strip():
                params[current] = f"{params[current]} {line.strip()}".strip()
    text = "\n".join(description).strip()
    return text.split("\n\n", 1)[0].replace("\n", " ") if text else "", params


def _is_context(annotation: Any) -> bool:
    return annotation is ToolContext or (isinstance(annotation, str) and annotation.endswith("ToolContext"))


def spec_from_function(
    fn: Callable[..., Any], *, name: str | None = None, description: str | None = None, **options: Any
) -> ToolSpec:
    """The :class:`ToolSpec` of a typed function (what ``@tool`` attaches)."""
    tool_name = name or f"{fn.__module__.rsplit('.', 1)[-1]}.{fn.__name__}"
    try:
        hints = typing.get_type_hints(fn, include_extras=True)
    except Exception as exc:
        raise ToolDefinitionError(
            f"tool {tool_name!r}: cannot resolve the type hints of {fn.__name__}: {exc}"
        ) from None
    summary, param_docs = parse_docstring(fn.__doc__)
    fields: dict[str, Any] = {}
    order: list[tuple[str, bool]] = []  # (parameter, passed by position) in signature order
    context_param: str | None = None
    for param in inspect.signature(fn).parameters.values():
        annotation = hints.get(param.name, Any)
        order.append((param.name, param.kind is param.POSITIONAL_ONLY))
        if _is_context(annotation):
            context_param = param.name
            continue
        if param.kind in (param.VAR_POSITIONAL, param.VAR_KEYWORD):
            raise ToolDefinitionError(f"tool {tool_name!r}: *{param.name} cannot be described by a schema")
        if param.name not in hints:
            raise ToolDefinitionError(f"tool {tool_name!r}: parameter {param.name!r} needs a type hint")
        default = ... if param.default is param.empty else param.default
        doc = param_docs.get(param.name)
        if isinstance(default, FieldInfo) or not doc:
            fields[param.name] = (annotation, default)  # an Annotated Field keeps its own description
        else:
            fields[param.name] = (annotation, Field(default, description=doc))
    try:
        model = create_model(
            f"{fn.__name__}_arguments", __config__=ConfigDict(extra="forbid", arbitrary_types_allowed=False), **fields
        )
        input_schema = model.model_json_schema()
    except Exception as exc:
        raise ToolDefinitionError(f"tool {tool_name!r}: its parameters have no JSON Schema: {exc}") from None
    input_schema.pop("title", None)
    output_schema, convert = _output(tool_name, hints)
    is_async = inspect.iscoroutinefunction(fn)

    def handler(args: dict[str, Any], context: ToolContext) -> Any:
        values = model.model_validate(args) if fields else None
        positional: list[Any] = []
        keywords: dict[str, Any] = {}
        for param, by_position in order:
            value = context if param == context_param else getattr(values, param)
            if by_position:
                positional.append(value)
            else:
                keywords[param] = value
        return fn(*positional, **keywords)

    return ToolSpec(
        name=tool_name,
        description=description if description is not None else summary,
        input_schema=input_schema,
        output_schema=output_schema,
        handler=handler,
        is_async=is_async,
        source="python",
        convert_output=convert,
        **spec_options(tool_name, **options),
    )


def _output(name: str, hints: dict[str, Any]) -> tuple[dict[str, Any] | None, Any]:
    if "return" not in hints:
        return None, None
    returns = hints["return"]
    if get_origin(returns) in (typing.Awaitable, typing.Coroutine):
        returns = typing.get_args(returns)[-1]
    try:
        adapter: TypeAdapter[Any] = TypeAdapter(returns)
        schema = adapter.json_schema(mode="serialization")
    except Exception as exc:
        raise ToolDefinitionError(f"tool {name!r}: its return type has no JSON Schema: {exc}") from None
    schema.pop("title", None)
    plain = returns in (str, int, float, bool, type(None))

    def convert(value: Any) -> Any:
        if plain and type(value) is returns:
            return value
        try:
            return adapter.dump_python(adapter.validate_python(value), mode="json")
        except ValidationError as exc:
            problem = exc.errors()[0]
            where = "$" + "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in problem["loc"])
            raise ToolError(f"the tool's output does not match its schema: {where}: {problem['msg']}") from None
        except Exception as exc:  # e.g. a value pydantic cannot serialise
            raise ToolError(f"the tool's output cannot be turned into JSON: {exc}") from None

    return schema, convert


@overload
def tool(fn: F, /) -> F: ...
@overload
def tool(*, name: str | None = None, description: str | None = None, **options: Any) -> Callable[[F], F]: ...
def tool(fn: Any = None, /, *, name: str | None = None, description: str | None = None, **options: Any) -> Any:
    """Make a typed function a tool. Options: ``scopes``, ``rate_limit`` ("10/s"), ``caller_rate_limit``,
    ``burst``, ``timeout_s`` (default 30; per attempt), ``retry`` (attempts or a RetrySpec), ``cache_ttl_s``,
    ``idempotent``, ``breaker`` (a BreakerPolicy), ``untrusted_output``, ``side_effects``, ``sensitive_args``,
    ``available``. ``idempotent`` promises that calling twice does no harm and that equal arguments give the same
    answer for every caller: such a tool may be cached (one cache per tool, shared by callers) and retried after a
    timeout. ``side_effects`` says the tool acts outside the run (sends, writes, releases): a call with an
    ``idempotency_key`` that already ended ok is then replayed from the audit log instead of run again.

    >>> @tool(name="weather.wind", scopes=["weather:read"], idempotent=True, cache_ttl_s=60)
    ... def wind(lat: float, lon: float) -> float:
    ...     '''Wind speed in m/s at a place.
    ...
    ...     Args:
    ...         lat: latitude in degrees
    ...         lon: longitude in degrees
    ...     '''
    ...     return 4.2
    >>> spec = tool_spec(wind)
    >>> spec.input_schema["properties"]["lat"]["description"], spec.output_schema
    ('latitude in degrees', {'type': 'number'})
    >>> wind(21.4, 39.8)  # still a plain function
    4.2
    """

    def decorate(function: F) -> F:
        spec = spec_from_function(function, name=name, description=description, **options)
        setattr(function, SPEC_ATTRIBUTE, spec)
        return function

    return decorate(fn) if fn is not None else decorate


def tool_spec(fn: Callable[..., Any]) -> ToolSpec:
    """The spec ``@tool`` attached to a function."""
    spec = getattr(fn, SPEC_ATTRIBUTE, None)
    if not isinstance(spec, ToolSpec):
        raise ToolDefinitionError(f"{getattr(fn, '__name__', fn)!r} is not a tool: decorate it with @tool")
    return spec


def is_tool(value: Any) -> bool:
    return isinstance(getattr(value, SPEC_ATTRIBUTE, None), ToolSpec)


__all__ = ["is_tool", "parse_docstring", "spec_from_function", "tool", "tool_spec"]
