"""One call of an HTTP endpoint tool: arguments placed in the path, query and body, the credential added, the
answer read (bounded) and turned into a value or a retryable or final failure. See :mod:`tools.http_endpoint`.
"""

from __future__ import annotations

import codecs
import json
import os
import re
from typing import TYPE_CHECKING, Any
from urllib.parse import quote, quote_plus, urlsplit

import httpx

from .egress import MAX_REDIRECTS, AsyncEgressTransport, EgressPolicy, fenced
from .errors import ToolError, TransientToolError
from .idempotency import header_value

if TYPE_CHECKING:
    from .http_endpoint import HttpEndpoint

BODY_METHODS = frozenset({"POST", "PUT", "PATCH"})
TEXT_LIMIT_BYTES = 100_000
MAX_RESPONSE_BYTES = 10 * 1024 * 1024
EXCERPT_CHARS = 300
PLACEHOLDER = re.compile(r"\{([^{}]*)\}")


def _query_value(value: Any) -> Any:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return json.dumps(value, separators=(",", ":"))
    if isinstance(value, list):
        return [_query_value(v) for v in value]
    return value


def _path_value(value: Any) -> str:
    return quote(value if isinstance(value, str) else str(_query_value(value)), safe="")


def _decode(content: bytes, encoding: str | None) -> str:
    """Text of possibly cut bytes: an incomplete last character is dropped, not turned into a replacement mark."""
    try:
        decoder = codecs.getincrementaldecoder(encoding or "utf-8")(errors="replace")
    except LookupError:
        decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
    return decoder.decode(content, final=False)


def _scrub(text: str, secret: str | None) -> str:
    """``text`` without the secret, as written or as a URL or JSON quotes it (an error page echoing the URL)."""
    if not secret:
        return text
    escaped = json.dumps(secret)[1:-1]
    forms = {secret, quote(secret, safe=""), quote_plus(secret), escaped, escaped.replace("/", "\\/")}
    for form in sorted(forms, key=len, reverse=True):
        text = text.replace(form, "***")
    return text


class EndpointCall:
    """Calls one endpoint; shared by every call of its tool (it holds no per-call state)."""

    def __init__(self, endpoint: HttpEndpoint, transport: httpx.AsyncBaseTransport | None = None) -> None:
        self.endpoint = endpoint
        self.transport = transport
        properties = endpoint.params.get("properties") or {}
        self.defaults = {k: v["default"] for k, v in properties.items() if isinstance(v, dict) and "default" in v}
        self.path_names = set(PLACEHOLDER.findall(endpoint.url))
        self.host = urlsplit(PLACEHOLDER.sub("x", endpoint.url)).netloc

    def request_parts(self, args: dict[str, Any]) -> tuple[str, dict[str, Any], dict[str, Any]]:
        """The URL, query parameters and JSON body for ``args`` (defaults filled in)."""
        endpoint = self.endpoint
        values = {**self.defaults, **args}
        url = PLACEHOLDER.sub(lambda m: _path_value(values[m.group(1)]), endpoint.url)
        query: dict[str, Any] = {}
        body: dict[str, Any] = {}
        for name, value in values.items():
            if name in self.path_names:
                continue
            if endpoint.method in BODY_METHODS and name not in endpoint.query:
                body[name] = value
            elif value is not None:
                query[name] = _query_value(value)
        return url, query, body

    async def __call__(self, args: dict[str, Any], idempotency_key: str | None = None) -> Any:
        endpoint = self.endpoint
        url, query, body = self.request_parts(args)
        headers = dict(endpoint.headers)
        if idempotency_key is not None:
            headers["Idempotency-Key"] = header_value(idempotency_key)
        secret = self._secret()
        if secret is not None and endpoint.auth is not None:
            if endpoint.auth.query is not None:
                query[endpoint.auth.query] = secret
            else:
                scheme = endpoint.auth.scheme
                headers[endpoint.auth.header or "Authorization"] = f"{scheme} {secret}" if scheme else secret
        try:
            async with (
                httpx.AsyncClient(
                    timeout=endpoint.timeout_s,
                    transport=self.transport or AsyncEgressTransport(EgressPolicy.from_env()),
                    follow_redirects=True,
                    max_redirects=MAX_REDIRECTS,
                ) as client,
                client.stream(endpoint.method, url, params=query, json=body or None, headers=headers) as response,
            ):
                content = await self._read(response)
        except httpx.TransportError as exc:
            raise self._transport_failure(exc, secret) from None
        return self._result(response, content, secret)

    def _secret(self) -> str | None:
        auth = self.endpoint.auth
        if auth is None:
            return None
        secret = os.environ.get(auth.env)
        if not secret:
            raise ToolError(f"{self.endpoint.name} needs its credential in the environment variable {auth.env}: unset")
        return secret

    async def _read(self, response: httpx.Response) -> bytes:
        chunks: list[bytes] = []
        size = 0
        async for chunk in response.aiter_bytes():
            size += len(chunk)
            if size > MAX_RESPONSE_BYTES:
                raise ToolError(f"the answer from {self.host} is over {MAX_RESPONSE_BYTES // 2**20} MB; not read")
            chunks.append(chunk)
        return b"".join(chunks)

    def _transport_failure(self, exc: httpx.TransportError, secret: str | None) -> Exception:
        text = _scrub(f"{type(exc).__name__}: {exc}", secret)
        if isinstance(exc, httpx.ConnectError | httpx.ConnectTimeout | httpx.PoolTimeout):
            return TransientToolError(f"cannot reach {self.host}: {text}")
        if self.endpoint.idempotent:
            return TransientToolError(f"the link to {self.host} failed: {text}")
        return ToolError(f"the link to {self.host} failed after the request went out ({text}); not retried")

    def _result(self, response: httpx.Response, content: bytes, secret: str | None) -> Any:
        status = response.status_code
        text = _scrub(_decode(content, response.encoding), secret)
        where = f"HTTP {status} {response.reason_phrase} from {self.host}"
        if status in (429, 503) or (self.endpoint.idempotent and (status in (408, 425) or status >= 500)):
            raise TransientToolError(where)
        if status >= 300:
            excerpt = " ".join(text[:EXCERPT_CHARS].split())
            raise ToolError(f"{where}: {fenced(excerpt, EXCERPT_CHARS)}" if excerpt else where)
        content_type = response.headers.get("content-type")
        media = (content_type or "").split(";", 1)[0].strip().lower()
        if media == "application/json" or media.endswith("+json"):
            try:
                return json.loads(text)
            except ValueError:
                pass  # not JSON after all: returned as text
        truncated = len(content) > TEXT_LIMIT_BYTES
        if truncated:
            text = _scrub(_decode(content[:TEXT_LIMIT_BYTES], response.encoding), secret)
        size = len(content)
        return {"status": status, "content_type": content_type, "text": text, "truncated": truncated, "bytes": size}


__all__ = ["BODY_METHODS", "PLACEHOLDER", "TEXT_LIMIT_BYTES", "EndpointCall"]
