"""An MCP client for external servers (a spawned process on stdio, or Streamable HTTP), and
:func:`import_mcp_tools`, which makes each remote tool one of ours, behind the executor's guards.

The client is thread-based: its methods work from plain code, and their ``a``-prefixed twins from any event loop,
so an imported tool runs whether the executor calls it synchronously or on a loop.

Spec facts relied on (MCP 2025-06-18 and 2025-11-25 ``basic/lifecycle.mdx``, ``server/tools.mdx``,
``server/utilities/pagination.mdx``): the client opens with ``initialize`` (its latest version), disconnects if it
does not speak the version the server answers, then sends ``notifications/initialized``; ``tools/list`` pages
follow ``nextCursor`` until it is absent; a tool result's ``isError`` marks a failed call, ``structuredContent``
holds structured output; a request the client stops waiting for is cancelled with ``notifications/cancelled``.

>>> from tools import ToolExecutor, ToolRegistry
>>> from tools.mcp import McpServer, serve_http
>>> remote = ToolRegistry()
>>> @remote.tool(name="math.add")
... def add(a: int, b: int) -> int:
...     return a + b
>>> handle = serve_http(McpServer(ToolExecutor(remote)))
>>> local = ToolRegistry()
>>> with McpClient.http(handle.url) as client:
...     import_mcp_tools(local, client, namespace="calc")
...     ToolExecutor(local).call("calc.math.add", {"a": 2, "b": 3}).output
['calc.math.add']
'5'
>>> handle.close()
"""

from __future__ import annotations

import asyncio
import hashlib
import itertools
import logging
import re
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from typing import IO, Any

from ..errors import ToolDefinitionError, ToolError
from ..registry import ToolRegistry
from ..security import scan_value
from ..spec import MAX_NAME_LENGTH, ToolContext, ToolSpec
from . import protocol as p
from .client_transports import ClientTransport, HttpTransport, McpError, SessionExpired, StdioTransport
from .server import _package_version

log = logging.getLogger("tools.mcp.client")

MAX_PAGES = 1000


class McpClient:
    """A connection to one MCP server. Build it with :meth:`stdio` or :meth:`http`; it connects on first use
    (or :meth:`connect`) and closes with :meth:`close` or at the end of a ``with`` / ``async with`` block.

    ``timeout_s`` bounds each request (None: wait as long as it takes); ``on_notification`` receives the
    server's notifications (on a transport thread).
    """

    def __init__(
        self,
        transport: ClientTransport,
        *,
        timeout_s: float | None = 30.0,
        name: str = "agentic-uavs",
        on_notification: Callable[[dict[str, Any]], None] | None = None,
    ) -> None:
        self.transport = transport
        self.timeout_s = timeout_s
        self.name = name
        self.on_notification = on_notification
        self.protocol_version: str | None = None
        self.server_info: dict[str, Any] = {}
        self.capabilities: dict[str, Any] = {}
        self.instructions: str | None = None
        self.tools_changed = threading.Event()  # set by notifications/tools/list_changed
        self._ids = itertools.count(1)
        self._lock = threading.Lock()
        self._connected = False
        transport.on_message = self._on_message

    @classmethod
    def stdio(
        cls,
        command: Sequence[str],
        *,
        env: Mapping[str, str] | None = None,
        cwd: str | None = None,
        stderr: IO[Any] | int | None = None,
        **options: Any,
    ) -> McpClient:
        """A client of the server that ``command`` starts (its stdin and stdout carry the messages)."""
        return cls(StdioTransport(command, env=env, cwd=cwd, stderr=stderr), **options)

    @classmethod
    def http(
        cls, url: str, *, token: str | None = None, headers: Mapping[str, str] | None = None, **options: Any
    ) -> McpClient:
        """A client of the Streamable HTTP server at ``url``; ``token`` is sent as a bearer token."""
        timeout = options.get("timeout_s", 30.0)  # also how long the transport waits for a silent server
        return cls(HttpTransport(url, token=token, headers=headers, timeout_s=timeout), **options)

    # connection ---------------------------------------------------------------------------------------------------
    def connect(self) -> McpClient:
        """Start the transport and run the ``initialize`` handshake (once)."""
        with self._lock:
            if not self._connected:
                self.transport.start()
                try:
                    self._handshake()
                except BaseException:
                    self.transport.close()
                    raise
                self._connected = True
        return self

    def _handshake(self) -> None:
        params = {
            "protocolVersion": p.LATEST_VERSION,
            "capabilities": {},
            "clientInfo": {"name": self.name, "version": _package_version()},
        }
        self.transport.protocol_version = None
        result = self._wait(self.transport.request(self._message("initialize", params), self.timeout_s), "initialize")
        version = result.get("protocolVersion")
        if version not in p.PROTOCOL_VERSIONS:
            raise McpError(f"the MCP server {self.transport.name} speaks protocol version {version!r}, we do not")
        self.protocol_version = self.transport.protocol_version = str(version)
        info, capabilities = result.get("serverInfo"), result.get("capabilities")
        self.server_info = dict(info) if isinstance(info, Mapping) else {}
        self.capabilities = dict(capabilities) if isinstance(capabilities, Mapping) else {}
        instructions = result.get("instructions")
        self.instructions = instructions if isinstance(instructions, str) else None
        self.transport.notify(p.notification("notifications/initialized"))

    def _renew(self) -> None:
        with self._lock:
            self.transport.new_session()
            self._handshake()

    def close(self) -> None:
        self.transport.close()

    def __enter__(self) -> McpClient:
        return self.connect()

    def __exit__(self, *exc: object) -> None:
        self.close()

    async def __aenter__(self) -> McpClient:
        await asyncio.to_thread(self.connect)
        return self

    async def __aexit__(self, *exc: object) -> None:
        await asyncio.to_thread(self.close)

    def _on_message(self, message: dict[str, Any]) -> None:
        if message.get("method") == "notifications/tools/list_changed":
            self.tools_changed.set()
        if self.on_notification is not None:
            try:
                self.on_notification(message)
            except Exception:
                log.exception("the MCP notification handler failed")

    # requests -----------------------------------------------------------------------------------------------------
    def _wait(self, future: Any, method: str, timeout_s: float | None = None) -> dict[str, Any]:
        timeout = timeout_s if timeout_s is not None else self.timeout_s
        try:
            response = future.result(timeout=timeout)
        except TimeoutError:
            future.cancel()
            raise TimeoutError(f"no answer to {method} from {self.transport.name} in {timeout:.3g} s") from None
        return _result(response)

    def request(self, method: str, params: Mapping[str, Any] | None = None, *, timeout_s: float | None = None) -> Any:
        """Send one request and wait for its result (a JSON-RPC error raises :class:`McpError`)."""
        self.connect()
        for attempt in (1, 2):
            try:
                future = self.transport.request(self._message(method, params), timeout_s or self.timeout_s)
                return self._wait(future, method, timeout_s)
            except SessionExpired:
                if attempt == 2:
                    raise
                self._renew()
        raise AssertionError("unreachable")

    async def arequest(
        self, method: str, params: Mapping[str, Any] | None = None, *, timeout_s: float | None = None
    ) -> Any:
        """:meth:`request` for code on an event loop (cancelling it cancels the request)."""
        if not self._connected:
            await asyncio.to_thread(self.connect)
        timeout = timeout_s if timeout_s is not None else self.timeout_s
        for attempt in (1, 2):
            future = asyncio.wrap_future(self.transport.request(self._message(method, params), timeout))
            try:
                async with asyncio.timeout(timeout):
                    return _result(await future)
            except SessionExpired:
                if attempt == 2:
                    raise
                await asyncio.to_thread(self._renew)
            except TimeoutError:
                raise TimeoutError(f"no answer to {method} from {self.transport.name} in {timeout:.3g} s") from None
        raise AssertionError("unreachable")

    def _message(self, method: str, params: Mapping[str, Any] | None) -> dict[str, Any]:
        return p.request(next(self._ids), method, params)

    def list_tools(self) -> list[dict[str, Any]]:
        """Every tool the server lists, following ``nextCursor`` page by page."""
        tools: list[dict[str, Any]] = []
        cursor: str | None = None
        for _ in range(MAX_PAGES):
            page = self.request("tools/list", {} if cursor is None else {"cursor": cursor})
            tools.extend(t for t in page.get("tools", []) if isinstance(t, dict) and isinstance(t.get("name"), str))
            next_cursor = page.get("nextCursor")
            if not isinstance(next_cursor, str) or not next_cursor or next_cursor == cursor:
                return tools
            cursor = next_cursor
        raise McpError(f"the MCP server {self.transport.name} listed more than {MAX_PAGES} pages of tools")

    async def alist_tools(self) -> list[dict[str, Any]]:
        return await asyncio.to_thread(self.list_tools)

    def call_tool(
        self, name: str, arguments: Mapping[str, Any] | None = None, *, timeout_s: float | None = None
    ) -> dict[str, Any]:
        """The raw ``CallToolResult`` of a remote tool (``content``, ``isError``, maybe ``structuredContent``)."""
        return dict(self.request("tools/call", {"name": name, "arguments": dict(arguments or {})}, timeout_s=timeout_s))

    async def acall_tool(
        self, name: str, arguments: Mapping[str, Any] | None = None, *, timeout_s: float | None = None
    ) -> dict[str, Any]:
        params = {"name": name, "arguments": dict(arguments or {})}
        return dict(await self.arequest("tools/call", params, timeout_s=timeout_s))


def _result(response: dict[str, Any]) -> dict[str, Any]:
    try:
        return p.unwrap(response)
    except p.JsonRpcError as exc:
        raise McpError(f"the MCP server answered: {exc.message}", code=exc.code, data=exc.data) from None


def tool_output(result: Mapping[str, Any]) -> Any:
    """What a ``CallToolResult`` gives our executor: its ``structuredContent`` when present, else its text
    (text items joined, other items described); :class:`ToolError` when it has ``isError``."""
    if result.get("isError"):
        raise ToolError(p.content_text(result.get("content")) or "the remote tool failed")
    if result.get("structuredContent") is not None:
        return result["structuredContent"]
    return p.content_text(result.get("content"))


_UNSAFE = re.compile(r"[^A-Za-z0-9_-]")
_NAMESPACE = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,31}$")


def local_name(namespace: str, remote: str, taken: set[str]) -> str:
    """``{namespace}.{remote}`` within our name rules: unsafe characters become ``_``, empty segments go, and a
    name too long or already taken gets a short hash of the remote name."""
    parts = [part for part in (_UNSAFE.sub("_", s) for s in remote.split(".")) if part] or ["tool"]
    name = ".".join([namespace, *parts])
    if len(name) > MAX_NAME_LENGTH or name in taken:
        digest = hashlib.sha256(remote.encode()).hexdigest()[:8]
        name = f"{name[: MAX_NAME_LENGTH - 9].rstrip('.')}_{digest}"
    return name


def import_mcp_tools(
    registry: ToolRegistry,
    client: McpClient,
    *,
    namespace: str = "ext",
    scopes: Sequence[str] = (),
    replace: bool = False,
    **spec_options: Any,
) -> list[str]:
    """Register every tool of ``client``'s server as ``{namespace}.{remote name}`` (source ``mcp``, output
    untrusted) and return the new names. Calling one calls the remote tool: a remote ``isError`` becomes a
    :class:`ToolError`, a lost or silent server a :class:`ConnectionError` or :class:`TimeoutError` (retryable).
    ``scopes`` and ``spec_options`` (``timeout_s``, ``retry``, ``rate_limit``, ...) apply to each tool. A tool whose
    schemas we cannot use, or whose description or schema reads like instructions to the model (the injection
    guard), is skipped with a warning."""
    if not _NAMESPACE.match(namespace):
        raise ToolDefinitionError(f"namespace {namespace!r}: a letter, then letters, digits, '_' or '-' (at most 32)")
    spec_options.pop("untrusted_output", None)
    taken = set(registry.names())
    names: list[str] = []
    for remote in client.list_tools():
        remote_name: str = remote["name"]
        name = local_name(namespace, remote_name, taken)
        input_schema = remote.get("inputSchema")
        output_schema = remote.get("outputSchema")
        description = remote.get("description") or remote.get("title") or remote_name
        report = scan_value({"description": description, "inputSchema": input_schema})
        if report.flagged:  # a description is read by the LLM: a planted instruction must not reach it
            found = ", ".join(sorted({f.kind for f in report.findings}))
            log.warning(
                "skipping the MCP tool %r of %s: its description reads like instructions (%s)",
                remote_name,
                client.transport.name,
                found,
            )
            continue
        try:
            spec = ToolSpec.from_schema(
                name,
                _remote_handler(client, remote_name),
                input_schema if isinstance(input_schema, Mapping) else {"type": "object"},
                description=str(description),
                output_schema=output_schema if isinstance(output_schema, Mapping) else None,
                source="mcp",
                scopes=tuple(scopes),
                untrusted_output=True,
                **spec_options,
            )
        except ToolDefinitionError as exc:
            log.warning("skipping the MCP tool %r of %s: %s", remote_name, client.transport.name, exc)
            continue
        registry.register(spec, replace=replace)
        taken.add(name)
        names.append(name)
    return names


def _remote_handler(client: McpClient, remote_name: str) -> Callable[[dict[str, Any], ToolContext], Any]:
    async def call_remote(args: dict[str, Any], context: ToolContext) -> Any:
        timeout = None
        if context.deadline is not None:
            timeout = max(context.deadline - time.monotonic(), 0.001)
        try:
            result = await client.acall_tool(remote_name, args, timeout_s=timeout)
        except McpError as exc:
            raise ToolError(str(exc)) from None
        return tool_output(result)

    return call_remote
