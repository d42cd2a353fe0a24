"""Tools from HTTP endpoint descriptions: a YAML or JSON file turns REST endpoints into guarded tools, no Python.

A file holds a ``tools`` list; each entry is one :class:`HttpEndpoint`::

    tools:
      - name: traffic.road_status          # namespace.name
        description: Road closures near a point.
        method: GET                        # GET (default), POST, PUT, PATCH or DELETE
        url: https://api.example.org/v2/roads/{region}/status   # {param}: a path parameter, URL-quoted
        params:                            # JSON Schema of the tool's input (an object)
          type: object
          properties: {region: {type: string}, radius_km: {type: number, default: 5}}
          required: [region]
        query: [radius_km]                 # POST/PUT/PATCH: these go in the query string, the rest in a JSON body
        headers: {Accept: application/json}
        auth: {header: Authorization, env: TRAFFIC_API_TOKEN, scheme: Bearer}  # or {query: api_key, env: ...}
        output: {type: object}             # optional JSON Schema the answer must match
        timeout_s: 10                      # per attempt (default 30)
        rate_limit: 5/s                    # also caller_rate_limit
        scopes: [traffic:read]
        idempotent: true                   # default false; needed for cache_ttl_s
        side_effects: false                # true: it acts (creates, sends); a call with a key acts once
        cache_ttl_s: 60
        retry: 3                           # attempts in all (default 1)

GET and DELETE send every argument that is not a path parameter in the query string. Top-level defaults of
``params`` fill missing arguments; ``additionalProperties`` is false unless the schema says otherwise. The auth
secret is read from the environment at each call (a missing variable is an error result naming it, never a
crash) and never appears in a message. A JSON answer is returned parsed; any other is ``{"status",
"content_type", "text", "truncated", "bytes"}`` with the text cut at 100 kB. Idempotent endpoints retry
transport failures and HTTP 408/425/429/5xx; others retry only what cannot have been acted on (no connection,
HTTP 429 or 503). Every other status from 300 up is an error quoting it and the start of the body. A call
with an idempotency key sends it as the ``Idempotency-Key`` header. A bad file
raises :class:`ToolDefinitionError` listing every problem as ``file:line:col: field: message``.

>>> from tools import ToolExecutor, ToolRegistry
>>> endpoint = HttpEndpoint(name="roads.status", url="https://roads.example/{region}", params={
...     "type": "object", "properties": {"region": {"type": "string"}}, "required": ["region"]})
>>> fake = httpx.MockTransport(lambda request: httpx.Response(200, json={"path": str(request.url)}))
>>> registry = ToolRegistry()
>>> _ = registry.register(http_tool(endpoint, transport=fake))
>>> ToolExecutor(registry).call("roads.status", {"region": "Mina East"}).output
{'path': 'https://roads.example/Mina%20East'}

>>> import tempfile
>>> from pathlib import Path
>>> path = Path(tempfile.mkdtemp()) / "endpoints.yaml"
>>> _ = path.write_text("tools:\\n  - name: traffic.status\\n    method: FETCH\\n    url: https://x.org/{region}\\n")
>>> try:
...     load_http_tools(path)
... except ToolDefinitionError as exc:
...     print(str(exc).replace(str(path), "endpoints.yaml"))
endpoints.yaml:3:5: tools[0].method: 'FETCH' is not one of GET, POST, PUT, PATCH, DELETE
endpoints.yaml:4:5: tools[0].url: placeholder {region} is not a declared param (add it to params.properties)
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx
import jsonschema
from jsonschema.exceptions import SchemaError
from pydantic import BaseModel, ConfigDict, Field, ValidationError, ValidationInfo, field_validator, model_validator

from agentic_core.contracts.problems import LocatedProblem

from .errors import ToolDefinitionError
from .http_call import PLACEHOLDER, EndpointCall
from .ratelimit import RateLimit
from .registry import ToolRegistry
from .spec import MAX_NAME_LENGTH, NAME, RetrySpec, ToolContext, ToolSpec, declared_transient, is_transient
from .yaml_source import Loc, YamlSource, dotted

METHODS = ("GET", "POST", "PUT", "PATCH", "DELETE")
_IDENTIFIER = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_HEADER = re.compile(r"^[!#$%&'*+.^_`|~0-9A-Za-z-]+$")


class EndpointAuth(BaseModel):
    """A credential read from the environment at call time, sent in a header (default ``Authorization``, with an
    optional ``scheme`` such as ``Bearer``) or as a query parameter."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    env: str = Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]*$", description="the environment variable holding the secret")
    header: str | None = None
    query: str | None = None
    scheme: str | None = None

    @model_validator(mode="after")
    def _one_place(self) -> EndpointAuth:
        if self.header is not None and self.query is not None:
            raise ValueError("give 'header' or 'query', not both")
        return self


class HttpEndpoint(BaseModel):
    """One HTTP endpoint as a tool (the module docstring shows every field)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str
    description: str = ""
    method: str = "GET"
    url: str
    params: dict[str, Any] = Field(default_factory=lambda: {"type": "object", "properties": {}})
    query: list[str] = Field(default_factory=list)
    headers: dict[str, str] = Field(default_factory=dict)
    auth: EndpointAuth | None = None
    output: dict[str, Any] | None = None
    timeout_s: float = Field(default=30.0, gt=0, le=600)
    rate_limit: str | None = None
    caller_rate_limit: str | None = None
    scopes: list[str] = Field(default_factory=list)
    idempotent: bool = False
    side_effects: bool = False
    cache_ttl_s: float | None = Field(default=None, gt=0)
    retry: int = Field(default=1, ge=1, le=10)
    sensitive_args: list[str] = Field(default_factory=list)

    @field_validator("name")
    @classmethod
    def _name(cls, value: str) -> str:
        if not NAME.match(value) or len(value) > MAX_NAME_LENGTH:
            raise ValueError(f"{value!r} is not a tool name: write namespace.name, e.g. traffic.road_status")
        return value

    @field_validator("method")
    @classmethod
    def _method(cls, value: str) -> str:
        if value.upper() not in METHODS:
            raise ValueError(f"{value!r} is not one of {', '.join(METHODS)}")
        return value.upper()

    @field_validator("url")
    @classmethod
    def _url(cls, value: str) -> str:
        parts = urlsplit(PLACEHOLDER.sub("x", value))
        if parts.scheme not in ("http", "https") or not parts.netloc:
            raise ValueError(f"{value!r} is not an http:// or https:// URL")
        return value

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> HttpEndpoint:
        """Cross-field checks. A loader passes ``context={"problems": [...]}`` to collect them with their field
        paths; otherwise they raise together."""
        problems = endpoint_problems(self)
        sink = info.context.get("problems") if isinstance(info.context, dict) else None
        if isinstance(sink, list):
            sink.extend(problems)
        elif problems:
            raise ValueError("; ".join(f"{dotted(loc)}: {message}" for loc, message in problems))
        return self

    @property
    def placeholders(self) -> list[str]:
        return PLACEHOLDER.findall(self.url)


def _schema_problems(which: str, schema: Mapping[str, Any]) -> list[tuple[Loc, str]]:
    try:
        jsonschema.Draft202012Validator.check_schema(schema)
    except SchemaError as exc:
        return [((which, *exc.absolute_path), f"not valid JSON Schema: {exc.message}")]
    return []


def endpoint_problems(endpoint: HttpEndpoint) -> list[tuple[Loc, str]]:
    """What is inconsistent in a description, each with the path of the field to fix."""
    problems: list[tuple[Loc, str]] = []
    params = endpoint.params
    problems += _schema_problems("params", params)
    if params.get("type", "object") != "object":
        problems.append((("params", "type"), f"must be object (a tool takes named arguments), not {params['type']!r}"))
    properties: dict[str, Any] = params["properties"] if isinstance(params.get("properties"), dict) else {}
    required: list[Any] = params["required"] if isinstance(params.get("required"), list) else []
    for name in endpoint.placeholders:
        if not _IDENTIFIER.match(name):
            problems.append((("url",), f"placeholder {{{name}}} is not a parameter name"))
        elif name not in properties:
            problems.append((("url",), f"placeholder {{{name}}} is not a declared param (add it to params.properties)"))
        elif name not in required and "default" not in (properties[name] or {}):
            problems.append((("url",), f"path parameter {{{name}}} must be required or have a default"))
    for index, name in enumerate(endpoint.query):
        if name not in properties:
            problems.append((("query", index), f"{name!r} is not a declared param"))
        elif name in endpoint.placeholders:
            problems.append((("query", index), f"{name!r} is a path parameter ({{{name}}} in the url)"))
    for index, name in enumerate(endpoint.sensitive_args):
        if name not in properties:
            problems.append((("sensitive_args", index), f"{name!r} is not a declared param"))
    for header, value in endpoint.headers.items():
        if not _HEADER.match(header) or "\r" in value or "\n" in value:
            problems.append((("headers", header), "not a valid header name or value"))
    if endpoint.auth is not None and endpoint.auth.header is not None and not _HEADER.match(endpoint.auth.header):
        problems.append((("auth", "header"), f"{endpoint.auth.header!r} is not a header name"))
    if endpoint.output is not None:
        problems += _schema_problems("output", endpoint.output)
    for field in ("rate_limit", "caller_rate_limit"):
        text = getattr(endpoint, field)
        if text is not None:
            try:
                RateLimit.parse(text)
            except ToolDefinitionError as exc:
                problems.append(((field,), str(exc)))
    for index, scope in enumerate(endpoint.scopes):
        if not scope or " " in scope:
            problems.append((("scopes", index), f"bad scope {scope!r} (no spaces, not empty)"))
    if endpoint.cache_ttl_s is not None and not endpoint.idempotent:
        problems.append((("cache_ttl_s",), "only idempotent endpoints may cache results: add 'idempotent: true'"))
    return problems


def http_tool(endpoint: HttpEndpoint, *, transport: httpx.AsyncBaseTransport | None = None) -> ToolSpec:
    """The tool of one endpoint. ``transport`` replaces the network (an ``httpx.MockTransport``, a proxy)."""
    schema = {"type": "object", "additionalProperties": False, **endpoint.params}
    call = EndpointCall(endpoint, transport)

    async def handler(args: dict[str, Any], context: ToolContext) -> Any:
        return await call(args, context.idempotency_key)

    return ToolSpec.from_schema(
        endpoint.name,
        handler,
        schema,
        description=endpoint.description or f"{endpoint.method} {endpoint.url}",
        output_schema=endpoint.output,
        source="http",
        untrusted_output=True,
        scopes=endpoint.scopes,
        rate_limit=endpoint.rate_limit,
        caller_rate_limit=endpoint.caller_rate_limit,
        timeout_s=endpoint.timeout_s,
        retry=RetrySpec(attempts=endpoint.retry, retry_if=is_transient if endpoint.idempotent else declared_transient),
        cache_ttl_s=endpoint.cache_ttl_s,
        idempotent=endpoint.idempotent,
        side_effects=endpoint.side_effects,
        sensitive_args=endpoint.sensitive_args,
    )


# --- loading a file -----------------------------------------------------------------------------------------------
def _message(error: Mapping[str, Any]) -> str:
    kind, loc = error["type"], error["loc"]
    if kind == "missing":
        return "required field missing"
    if kind == "extra_forbidden":
        model = EndpointAuth if len(loc) >= 2 and loc[-2] == "auth" else HttpEndpoint
        close = difflib.get_close_matches(str(loc[-1]), list(model.model_fields), n=1)
        return "unknown field" + (
            f"; did you mean {close[0]!r}?" if close else f" (known: {', '.join(model.model_fields)})"
        )
    if kind == "value_error":
        return str(error["ctx"]["error"])
    return f"{error['msg']} (got {str(error.get('input'))[:40]!r})"


def _validate(item: Any) -> tuple[HttpEndpoint | None, list[tuple[Loc, str]]]:
    """One entry as an endpoint, and its problems: the field errors and, for the fields that are right, the
    cross-field ones too, so one run reports everything."""
    found: list[tuple[Loc, str]] = []
    try:
        return HttpEndpoint.model_validate(item, context={"problems": found}), found
    except ValidationError as exc:
        errors = exc.errors()
    problems: list[tuple[Loc, str]] = [(tuple(e["loc"]), _message(e)) for e in errors]
    if isinstance(item, dict):
        bad = {e["loc"][0] for e in errors if e["loc"]}
        rest = {key: value for key, value in item.items() if key not in bad}
        rest.setdefault("name", "placeholder.name")
        rest.setdefault("url", "http://placeholder")
        skip = bad | ({"url", "query", "sensitive_args"} if "params" in bad else set())
        found = []
        try:
            HttpEndpoint.model_validate(rest, context={"problems": found})
        except ValidationError:
            found = []
        problems += [(loc, message) for loc, message in found if loc[0] not in skip]
    return None, problems


def load_http_tools(path: str | Path, *, transport: httpx.AsyncBaseTransport | None = None) -> list[ToolSpec]:
    """The tools a description file defines; a :class:`ToolDefinitionError` lists every problem in it, one per
    line, as ``file:line:col: field: message`` (its ``problems``, in file order). ``transport`` replaces the
    network (tests, proxies)."""
    source = YamlSource.read(path)
    data = source.data
    problems = source.duplicate_keys()
    endpoints: list[tuple[int, HttpEndpoint]] = []
    if not isinstance(data, dict) or not isinstance(data.get("tools"), list) or not data["tools"]:
        problems.append((("tools",), "expected a non-empty 'tools:' list of endpoint descriptions"))
    else:
        problems += [((key,), "unknown top-level field (only 'tools')") for key in data if key != "tools"]
        first: dict[str, int] = {}
        for index, item in enumerate(data["tools"]):
            endpoint, found = _validate(item)
            problems += [(("tools", index, *loc), message) for loc, message in found]
            if endpoint is None:
                continue
            if endpoint.name in first:
                earlier, _ = source.position(("tools", first[endpoint.name], "name"))
                problems.append((("tools", index, "name"), f"{endpoint.name!r} is already defined (line {earlier})"))
            first.setdefault(endpoint.name, index)
            endpoints.append((index, endpoint))
    if problems:
        raise ToolDefinitionError([source.problem(loc, message) for loc, message in problems])
    specs = []
    for index, endpoint in endpoints:
        try:
            specs.append(http_tool(endpoint, transport=transport))
        except ToolDefinitionError as exc:  # checked above; kept so a gap still names the entry
            raise ToolDefinitionError([source.problem(("tools", index), str(exc))]) from None
    return specs


def register_http_tools(
    registry: ToolRegistry,
    path: str | Path,
    *,
    replace: bool = False,
    transport: httpx.AsyncBaseTransport | None = None,
) -> list[str]:
    """Register every tool of a description file (none when any is wrong or its name is taken); their names."""
    specs = load_http_tools(path, transport=transport)
    taken = [spec.name for spec in specs if spec.name in registry]
    if taken and not replace:
        taken_list = f"tools already registered: {', '.join(taken)} (pass replace=True)"
        raise ToolDefinitionError([LocatedProblem(str(path), None, None, taken_list)])
    return [registry.register(spec, replace=replace).name for spec in specs]


__all__ = [
    "METHODS",
    "EndpointAuth",
    "HttpEndpoint",
    "endpoint_problems",
    "http_tool",
    "load_http_tools",
    "register_http_tools",
]
