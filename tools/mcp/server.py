"""The MCP server: the registry's tools offered to any MCP client, every call through the guarded executor, and
the stdio transport (newline-delimited JSON-RPC on stdin/stdout, logs on stderr only, a clean end at EOF).

The server speaks ``initialize``, ``ping``, ``tools/list`` and ``tools/call`` (see :mod:`tools.mcp.protocol` for
the spec facts it keeps) and tells clients when the registry changes (``notifications/tools/list_changed``) on
transports that can push. The caller of a session holds the scopes; a tool it lacks a scope for answers a
``denied`` result with ``isError: true``.

>>> import asyncio
>>> from tools import Caller, ToolExecutor, ToolRegistry
>>> registry = ToolRegistry()
>>> @registry.tool(name="math.add")
... def add(a: int, b: int) -> int:
...     return a + b
>>> server = McpServer(ToolExecutor(registry))
>>> session = McpSession(Caller(id="local"))
>>> asyncio.run(server.handle({"jsonrpc": "2.0", "id": 1, "method": "initialize",
...     "params": {"protocolVersion": "2025-06-18", "capabilities": {}}}, session))["result"]["protocolVersion"]
'2025-06-18'
>>> asyncio.run(server.handle({"jsonrpc": "2.0", "id": 2, "method": "tools/call",
...     "params": {"name": "math.add", "arguments": {"a": 2, "b": 3}}}, session))["result"]["content"]
[{'type': 'text', 'text': '5'}]
"""

from __future__ import annotations

import asyncio
import contextlib
import importlib.metadata
import io
import logging
import threading
from collections.abc import Awaitable, Callable, Mapping
from typing import IO, Any

from ..auth import Caller
from ..executor import ToolExecutor
from . import protocol as p

log = logging.getLogger("tools.mcp")


def _package_version() -> str:
    try:
        return importlib.metadata.version("agentic-uavs")
    except importlib.metadata.PackageNotFoundError:
        return "0.0.0"


class McpSession:
    """One client connection: the negotiated version, whether the client said ``initialized``, who calls, the
    requests in flight (so ``notifications/cancelled`` can stop them) and, on transports that can push, how to
    send the client a message."""

    def __init__(self, caller: Caller, *, push: Callable[[dict[str, Any]], None] | None = None) -> None:
        self.caller = caller
        self.push = push
        self.protocol_version: str | None = None
        self.initialized = False
        self.client_info: dict[str, Any] = {}
        self.in_flight: dict[p.RequestId, asyncio.Task[Any]] = {}

    @property
    def batching(self) -> bool:
        return self.protocol_version in p.BATCHING_VERSIONS


_Method = Callable[[dict[str, Any], McpSession, Caller], Awaitable[dict[str, Any]]]


class McpServer:
    """JSON-RPC 2.0 over MCP for the tools of ``executor.registry``; ``page_size`` splits ``tools/list`` into
    pages (None: one page)."""

    def __init__(
        self,
        executor: ToolExecutor,
        *,
        name: str = "agentic-uavs",
        version: str | None = None,
        instructions: str | None = None,
        page_size: int | None = None,
    ) -> None:
        if page_size is not None and page_size < 1:
            raise ValueError("page_size must be at least 1")
        self.executor = executor
        self.registry = executor.registry
        self.name = name
        self.version = version or _package_version()
        self.instructions = instructions
        self.page_size = page_size
        self._methods: dict[str, _Method] = {
            "initialize": self._initialize,
            "ping": self._ping,
            "tools/list": self._list_tools,
            "tools/call": self._call_tool,
        }

    # entry points for transports ----------------------------------------------------------------------------------
    async def handle_text(self, text: str | bytes, session: McpSession, *, caller: Caller | None = None) -> str | None:
        """One line or body of JSON in, the JSON to answer with out (None: nothing to answer)."""
        try:
            message = p.decode(text)
        except p.JsonRpcError as exc:
            return p.encode(p.failure(None, exc))
        reply = await self.handle(message, session, caller=caller)
        return None if reply is None else p.encode(reply)

    async def handle(self, message: Any, session: McpSession, *, caller: Caller | None = None) -> Any:
        """One parsed message (or batch) in, the reply out: a response, a list of them, or None for notifications,
        responses and cancelled requests. ``caller`` overrides the session's (HTTP: the caller of this request)."""
        who = caller if caller is not None else session.caller
        if isinstance(message, list):
            if not session.batching:
                why = "batches are not supported" + (
                    f" in MCP {session.protocol_version}" if session.protocol_version else " before initialize"
                )
                return p.failure(None, p.JsonRpcError(p.INVALID_REQUEST, f"invalid request: {why}"))
            if not message:
                return p.failure(None, p.JsonRpcError(p.INVALID_REQUEST, "invalid request: an empty batch"))
            replies = await asyncio.gather(*(self._one(m, session, who, in_batch=True) for m in message))
            answered = [r for r in replies if r is not None]
            return answered or None
        return await self._one(message, session, who)

    def watch(self, session: McpSession) -> Callable[[], None]:
        """Tell the session's client when the registry changes (once it is initialized); returns a stop."""

        def changed() -> None:
            if session.initialized and session.push is not None:
                try:
                    session.push(p.notification("notifications/tools/list_changed"))
                except Exception:
                    log.debug("could not send tools/list_changed", exc_info=True)

        return self.registry.subscribe(changed)

    # dispatch -----------------------------------------------------------------------------------------------------
    async def _one(self, message: Any, session: McpSession, caller: Caller, *, in_batch: bool = False) -> Any:
        try:
            what = p.kind(message)
        except p.JsonRpcError as exc:
            return p.failure(p.message_id(message), exc)
        if what == "response":
            return None  # we send the client no requests, so there is nothing to match
        if what == "notification":
            self._notified(message, session)
            return None
        id_: p.RequestId = message["id"]
        method = message["method"]
        handler = self._methods.get(method)
        if handler is None:
            return p.failure(id_, p.JsonRpcError(p.METHOD_NOT_FOUND, f"method not found: {method}"))
        if method == "initialize" and in_batch:
            return p.failure(id_, p.JsonRpcError(p.INVALID_REQUEST, "invalid request: initialize in a batch"))
        if method not in ("initialize", "ping") and session.protocol_version is None:
            return p.failure(id_, p.JsonRpcError(p.INVALID_REQUEST, f"invalid request: {method} before initialize"))
        if isinstance(message.get("params"), list):
            return p.failure(id_, p.JsonRpcError(p.INVALID_PARAMS, "invalid params: MCP params are an object"))
        params = dict(message.get("params") or {})
        # Only tools/call awaits anything: the rest run at once, in order (an initialize is done before the next line)
        work = handler(params, session, caller)
        task = asyncio.ensure_future(work) if method == "tools/call" else None
        if task is not None:
            session.in_flight[id_] = task
        try:
            return p.success(id_, await (task or work))
        except p.JsonRpcError as exc:
            return p.failure(id_, exc)
        except asyncio.CancelledError:
            if task is not None and task.cancelled() and not _current_task_cancelling():
                return None  # cancelled by the client: no answer (spec: cancellation)
            raise
        except Exception as exc:
            log.exception("MCP %s failed", method)
            return p.failure(id_, p.JsonRpcError(p.INTERNAL_ERROR, f"internal error: {type(exc).__name__}: {exc}"))
        finally:
            if task is not None and session.in_flight.get(id_) is task:
                del session.in_flight[id_]

    def _notified(self, message: Mapping[str, Any], session: McpSession) -> None:
        method = message["method"]
        params = message.get("params")
        params = params if isinstance(params, Mapping) else {}
        if method == "notifications/initialized":
            session.initialized = session.protocol_version is not None
        elif method == "notifications/cancelled":
            request_id = params.get("requestId")
            task = session.in_flight.get(request_id) if p.is_id(request_id) else None
            if task is not None:
                task.cancel()

    # methods ------------------------------------------------------------------------------------------------------
    async def _initialize(self, params: dict[str, Any], session: McpSession, caller: Caller) -> dict[str, Any]:
        requested = params.get("protocolVersion")
        if not isinstance(requested, str):
            raise p.JsonRpcError(p.INVALID_PARAMS, "invalid params: 'protocolVersion' must be a string")
        if session.protocol_version is not None:
            raise p.JsonRpcError(p.INVALID_REQUEST, "invalid request: the session is already initialized")
        info = params.get("clientInfo")
        session.client_info = dict(info) if isinstance(info, Mapping) else {}
        session.protocol_version = p.negotiate(requested)
        result: dict[str, Any] = {
            "protocolVersion": session.protocol_version,
            "capabilities": {"tools": {"listChanged": True}},
            "serverInfo": {"name": self.name, "version": self.version},
        }
        if self.instructions:
            result["instructions"] = self.instructions
        return result

    async def _ping(self, params: dict[str, Any], session: McpSession, caller: Caller) -> dict[str, Any]:
        return {}

    async def _list_tools(self, params: dict[str, Any], session: McpSession, caller: Caller) -> dict[str, Any]:
        tools = self.registry.to_mcp()
        cursor = params.get("cursor")
        start = 0
        if cursor is not None:
            if not isinstance(cursor, str) or not cursor.isdigit() or int(cursor) > len(tools):
                raise p.JsonRpcError(p.INVALID_PARAMS, f"invalid params: unknown cursor {cursor!r}")
            start = int(cursor)
        end = len(tools) if self.page_size is None else start + self.page_size
        result: dict[str, Any] = {"tools": tools[start:end]}
        if end < len(tools):
            result["nextCursor"] = str(end)
        return result

    async def _call_tool(self, params: dict[str, Any], session: McpSession, caller: Caller) -> dict[str, Any]:
        name = params.get("name")
        arguments = params.get("arguments", {})
        if not isinstance(name, str):
            raise p.JsonRpcError(p.INVALID_PARAMS, "invalid params: 'name' must be a string")
        if not isinstance(arguments, Mapping):
            raise p.JsonRpcError(p.INVALID_PARAMS, "invalid params: 'arguments' must be an object")
        entry = self.registry.entry(name) or self.registry.entry(self.registry.resolve(name))
        if entry is None:
            closest = self.registry.closest(name)
            hint = f"; did you mean {', '.join(closest)}?" if closest else ""
            raise p.JsonRpcError(p.INVALID_PARAMS, f"Unknown tool: {name}{hint}")
        result = await self.executor.acall(name, arguments, caller=caller)
        schema = entry.spec.output_schema
        return p.call_result(result, structured=schema is not None and schema.get("type") == "object")


def _current_task_cancelling() -> bool:
    """Whether the task running this code is itself being cancelled (not only the request it awaited)."""
    current = asyncio.current_task()
    return current is not None and current.cancelling() > 0


# stdio ----------------------------------------------------------------------------------------------------------
class _LineWriter:
    """Writes whole messages, one per line, from any thread; a closed output only drops messages."""

    def __init__(self, stream: IO[Any]) -> None:
        self.stream: Any = stream
        self.binary = not isinstance(stream, io.TextIOBase)
        self.lock = threading.Lock()

    def write(self, line: str) -> None:
        with self.lock:
            try:
                self.stream.write((line + "\n").encode() if self.binary else line + "\n")
                self.stream.flush()
            except (OSError, ValueError):
                log.debug("stdout is closed; a message was dropped")


async def aserve_stdio(
    server: McpServer, stdin: IO[Any], stdout: IO[Any], *, caller: Caller | None = None, grace_s: float = 10.0
) -> None:
    """:func:`serve_stdio` for code already on an event loop."""
    source: Any = stdin
    loop = asyncio.get_running_loop()
    lines: asyncio.Queue[bytes | str | None] = asyncio.Queue()
    writer = _LineWriter(stdout)

    def push(message: dict[str, Any]) -> None:  # from the thread that changed the registry: it must not wait
        loop.call_soon_threadsafe(writer.write, p.encode(message))

    session = McpSession(caller or server.executor.default_caller, push=push)

    def read() -> None:
        try:
            for line in iter(source.readline, "" if isinstance(source, io.TextIOBase) else b""):
                loop.call_soon_threadsafe(lines.put_nowait, line)
        except (OSError, ValueError):
            log.debug("stdin failed", exc_info=True)
        finally:
            with contextlib.suppress(RuntimeError):  # the loop is gone: nobody waits for the end
                loop.call_soon_threadsafe(lines.put_nowait, None)

    async def answer(line: bytes | str) -> None:
        reply = await server.handle_text(line, session)
        if reply is not None:
            writer.write(reply)

    stop_watching = server.watch(session)
    threading.Thread(target=read, name="mcp-stdin", daemon=True).start()
    pending: set[asyncio.Task[None]] = set()
    try:
        while (line := await lines.get()) is not None:
            if not line.strip():
                continue
            task = asyncio.ensure_future(answer(line))
            pending.add(task)
            task.add_done_callback(pending.discard)
        if pending:  # EOF: finish what was asked (for a while), then end
            await asyncio.wait(set(pending), timeout=grace_s)
    finally:
        stop_watching()
        for task in list(pending):
            task.cancel()


def serve_stdio(
    server: McpServer, stdin: IO[Any], stdout: IO[Any], *, caller: Caller | None = None, grace_s: float = 10.0
) -> None:
    """Serve one client on ``stdin``/``stdout`` (text or binary streams) until ``stdin`` ends, then give the
    requests still running ``grace_s`` seconds to answer. Requests run concurrently, so a ping is answered while a
    tool runs. ``caller`` holds the scopes (default: the executor's default caller).

    >>> import io
    >>> from tools import ToolExecutor, ToolRegistry
    >>> out = io.StringIO()
    >>> server = McpServer(ToolExecutor(ToolRegistry()))
    >>> serve_stdio(server, io.StringIO('{"jsonrpc":"2.0","id":7,"method":"x"}\\n'), out)
    >>> out.getvalue()
    '{"jsonrpc":"2.0","id":7,"error":{"code":-32601,"message":"method not found: x"}}\\n'
    """
    asyncio.run(aserve_stdio(server, stdin, stdout, caller=caller, grace_s=grace_s))
