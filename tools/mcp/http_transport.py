"""Streamable HTTP for the MCP server, on the standard library's threading HTTP server: one endpoint (``/mcp``),
sessions, bearer-token callers, and an SSE stream (GET) on which clients hear ``notifications/tools/list_changed``.

Spec facts relied on (MCP 2025-06-18 and 2025-11-25 ``basic/transports.mdx``, ``basic/authorization.mdx``):

- one endpoint path for POST, GET and DELETE; a POSTed request is answered with ``application/json`` (we open no
  SSE stream for a POST, which the spec allows); a POSTed notification or response is answered ``202 Accepted``
  with no body, or an HTTP error whose body may be a JSON-RPC error without id;
- the server may issue ``Mcp-Session-Id`` (visible ASCII) with the ``InitializeResult``; later requests must carry
  it: without it ``400``, unknown or terminated ``404``; DELETE ends a session;
- later requests carry ``MCP-Protocol-Version``: an invalid or unsupported one is ``400``; absent, the negotiated
  version holds;
- GET opens an SSE stream for server messages, or ``405``; a message goes on one stream only (so one GET stream per
  session here; a second one is ``409``);
- the ``Origin`` header is validated on every request, an invalid one is ``403`` (2025-11-25); local servers should
  bind to 127.0.0.1; a missing or invalid bearer token is ``401`` with ``WWW-Authenticate: Bearer`` (RFC 6750).

>>> from tools import ToolExecutor, ToolRegistry
>>> from tools.mcp import McpServer
>>> handle = serve_http(McpServer(ToolExecutor(ToolRegistry())), "127.0.0.1", 0)
>>> handle.url.startswith("http://127.0.0.1:") and handle.url.endswith("/mcp")
True
>>> handle.close()
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import ipaddress
import logging
import queue
import secrets
import socket
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any
from urllib.parse import urlsplit

from agentic_core.contracts.errors import AgenticUAVError

from ..auth import Caller, InvalidToken, TokenAuthority
from . import protocol as p
from .anonymous import check_anonymous
from .refused import audit_refused
from .server import McpServer, McpSession

log = logging.getLogger("tools.mcp.http")

MAX_BODY_BYTES = 4 * 1024 * 1024
MAX_SESSIONS = 1000
MAX_SESSIONS_PER_CALLER = 100


def is_loopback(host: str) -> bool:
    """``localhost`` or a loopback address (127.0.0.0/8, ::1)."""
    if host.lower() == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


@dataclass(eq=False)
class _HttpSession:
    id: str
    mcp: McpSession
    owner: str
    last_seen: float = field(default_factory=time.monotonic)
    stream: queue.Queue[dict[str, Any] | None] | None = None
    stop_watching: Callable[[], None] = lambda: None

    def push(self, message: dict[str, Any]) -> None:
        stream = self.stream
        if stream is not None:  # with no GET stream open, a list_changed hint is dropped
            stream.put(message)

    def end(self) -> None:
        self.stop_watching()
        self.stop_watching = lambda: None
        if self.stream is not None:
            self.stream.put(None)


class _Rejected(AgenticUAVError):
    def __init__(
        self, status: int, message: str, headers: dict[str, str] | None = None, *, token: str | None = None
    ) -> None:
        super().__init__(message)
        self.status = status
        self.headers = headers or {}
        self.token = token  # the bearer token refused, if that is why


@dataclass(eq=False)
class _Endpoint:
    """What the request handlers share: the MCP server, its event loop, the sessions and the checks."""

    server: McpServer
    authority: TokenAuthority | None
    caller: Caller
    path: str
    loopback: bool
    allowed_origins: frozenset[str]
    session_idle_s: float
    keepalive_s: float
    sessions: dict[str, _HttpSession] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)
    closing: threading.Event = field(default_factory=threading.Event)
    loop: asyncio.AbstractEventLoop = field(default_factory=asyncio.new_event_loop)

    def run(self, coroutine: Any) -> Any:
        try:
            return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result()
        except concurrent.futures.CancelledError:
            raise _Rejected(503, "the server is shutting down") from None

    def stop_loop(self) -> None:
        """Cancel what still runs (its requests answer 503), then stop the loop."""

        async def cancel_all() -> None:
            tasks = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
            for task in tasks:
                task.cancel()
            await asyncio.gather(*tasks, return_exceptions=True)

        if self.loop.is_running():
            with contextlib.suppress(concurrent.futures.TimeoutError):
                asyncio.run_coroutine_threadsafe(cancel_all(), self.loop).result(timeout=5)
            self.loop.call_soon_threadsafe(self.loop.stop)

    # checks -------------------------------------------------------------------------------------------------------
    def admit(self, h: BaseHTTPRequestHandler) -> Caller:
        """The caller of a request to the endpoint; :class:`_Rejected` when it may not be served."""
        if urlsplit(h.path).path.rstrip("/") != self.path.rstrip("/"):
            raise _Rejected(404, f"not found: the MCP endpoint is {self.path}")
        if self.loopback:
            host = urlsplit(f"//{h.headers.get('Host', '')}").hostname or ""
            if not is_loopback(host):
                raise _Rejected(421, f"invalid Host header {h.headers.get('Host')!r}")
        origin = h.headers.get("Origin")
        if origin is not None and origin.rstrip("/") not in self.allowed_origins:
            origin_host = urlsplit(origin).hostname if origin.startswith(("http://", "https://")) else None
            if origin_host is None or not is_loopback(origin_host):
                raise _Rejected(403, f"forbidden origin {origin!r}")
        if self.authority is None:
            return self.caller
        scheme, _, token = (h.headers.get("Authorization") or "").partition(" ")
        if scheme.lower() != "bearer" or not token.strip():
            raise _Rejected(401, "a bearer token is required", {"WWW-Authenticate": 'Bearer realm="mcp"'})
        try:
            return self.authority.verify(token.strip())
        except InvalidToken as exc:
            detail = str(exc).replace('"', "'")
            challenge = f'Bearer realm="mcp", error="invalid_token", error_description="{detail}"'
            raise _Rejected(401, str(exc), {"WWW-Authenticate": challenge}, token=token.strip()) from None

    def session(self, h: BaseHTTPRequestHandler, caller: Caller) -> _HttpSession:
        session_id = h.headers.get(p.SESSION_HEADER)
        if not session_id:
            raise _Rejected(400, f"missing {p.SESSION_HEADER} header: send initialize first")
        with self.lock:
            session = self.sessions.get(session_id)
        if session is None or session.owner != caller.id:  # another caller's session is not one of yours
            raise _Rejected(404, "unknown or terminated session: send initialize again")
        version = h.headers.get(p.VERSION_HEADER)
        if version is not None and version != session.mcp.protocol_version:
            raise _Rejected(400, f"unsupported {p.VERSION_HEADER} {version!r} for this session")
        session.last_seen = time.monotonic()
        return session

    def open_session(self, mcp: McpSession, caller: Caller) -> _HttpSession:
        with self.lock:
            now = time.monotonic()
            for key, old in list(self.sessions.items()):
                if old.stream is None and now - old.last_seen > self.session_idle_s:
                    del self.sessions[key]
                    old.end()
            mine = [old for old in self.sessions.values() if old.owner == caller.id]
            if len(mine) >= MAX_SESSIONS_PER_CALLER:
                if self.authority is None:  # every local process is this one caller: end no one's session
                    raise _Rejected(503, f"{len(mine)} sessions open: end one (DELETE) first", {"Retry-After": "60"})
                oldest = min(mine, key=lambda old: old.last_seen)  # a caller's flood ends its own, no one else's
                mine.remove(oldest)
                self._evict(oldest)
            if len(self.sessions) >= MAX_SESSIONS:
                idle = [old for old in mine if old.stream is None]
                if not idle or self.authority is None:
                    raise _Rejected(503, "too many sessions", {"Retry-After": "60"})
                self._evict(min(idle, key=lambda old: old.last_seen))
            session = _HttpSession(secrets.token_urlsafe(24), mcp, caller.id)
            self.sessions[session.id] = session
        mcp.push = session.push
        session.stop_watching = self.server.watch(mcp)
        return session

    def _evict(self, session: _HttpSession) -> None:
        """End the least recently used session to make room (the lock is held); its client re-initializes."""
        del self.sessions[session.id]
        session.end()

    def end_session(self, session: _HttpSession) -> None:
        with self.lock:
            self.sessions.pop(session.id, None)
        session.end()

    # methods ------------------------------------------------------------------------------------------------------
    def post(self, h: _Handler) -> None:
        try:
            caller = self.admit(h)
        except _Rejected as exc:
            size = h.headers.get("Content-Length") or ""
            if exc.token is not None and size.isdigit() and int(size) <= MAX_BODY_BYTES:
                audit_refused(self.server.executor, h.rfile.read(int(size)), exc.token, str(exc))
            raise
        if not (h.headers.get("Content-Type") or "").lower().startswith("application/json"):
            raise _Rejected(415, "the body must be application/json")
        accept = (h.headers.get("Accept") or "*/*").lower()
        if not any(kind in accept for kind in ("application/json", "application/*", "*/*")):
            raise _Rejected(406, "the client must accept application/json")
        length = h.headers.get("Content-Length")
        if length is None or not length.isdigit():
            raise _Rejected(411, "a Content-Length is required")
        if int(length) > MAX_BODY_BYTES:
            raise _Rejected(413, f"the body is larger than {MAX_BODY_BYTES} bytes")
        try:
            message = p.decode(h.rfile.read(int(length)))
        except p.JsonRpcError as exc:
            return h.reply(400, p.failure(None, exc))
        if isinstance(message, dict) and message.get("method") == "initialize":
            mcp = McpSession(caller)
            reply = self.run(self.server.handle(message, mcp, caller=caller))
            if mcp.protocol_version is None:
                return h.reply(200, reply)
            session = self.open_session(mcp, caller)
            return h.reply(200, reply, {p.SESSION_HEADER: session.id})
        session = self.session(h, caller)
        reply = self.run(self.server.handle(message, session.mcp, caller=caller))
        if reply is None:
            return h.reply(202)
        if isinstance(reply, dict) and reply.get("id") is None and "error" in reply:
            return h.reply(400, reply)  # the body was no JSON-RPC message we could take
        h.reply(200, reply)

    def get(self, h: _Handler) -> None:
        session = self.session(h, self.admit(h))
        if "text/event-stream" not in (h.headers.get("Accept") or "").lower():
            raise _Rejected(406, "the client must accept text/event-stream")
        stream: queue.Queue[dict[str, Any] | None] = queue.Queue()
        with self.lock:
            if session.stream is not None:
                raise _Rejected(409, "this session already has a GET stream open")
            session.stream = stream
        try:
            h.close_connection = True
            h.send_response(200)
            h.send_header("Content-Type", "text/event-stream")
            h.send_header("Cache-Control", "no-cache")
            h.send_header("Connection", "close")
            h.end_headers()
            h.wfile.flush()
            while not self.closing.is_set():
                try:
                    item = stream.get(timeout=self.keepalive_s)
                except queue.Empty:
                    h.wfile.write(b": keep-alive\n\n")
                else:
                    if item is None:
                        break
                    h.wfile.write(f"event: message\ndata: {p.encode(item)}\n\n".encode())
                h.wfile.flush()
        except OSError:
            log.debug("the client closed its GET stream")
        finally:
            with self.lock:
                if session.stream is stream:
                    session.stream = None

    def delete(self, h: _Handler) -> None:
        session = self.session(h, self.admit(h))
        self.end_session(session)
        h.reply(204)


class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    timeout = 120.0  # seconds a socket read or write may block: a stalled client frees its thread
    server: _Server

    def setup(self) -> None:
        super().setup()
        self.connection.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)  # headers and body go out at once

    def reply(self, status: int, body: Any = None, headers: dict[str, str] | None = None) -> None:
        data = b"" if body is None else p.encode(body).encode()
        self.send_response(status)
        if body is not None:
            self.send_header("Content-Type", "application/json")
        if status != 204:
            self.send_header("Content-Length", str(len(data)))
        for name, value in (headers or {}).items():
            self.send_header(name, value)
        if self.close_connection:
            self.send_header("Connection", "close")
        self.end_headers()
        self.wfile.write(data)

    def _serve(self, method: Callable[[_Handler], None]) -> None:
        try:
            try:
                method(self)
            except _Rejected as exc:
                self.close_connection = True  # the body may be unread: never parse it as the next request
                self.reply(exc.status, p.failure(None, p.JsonRpcError(p.INVALID_REQUEST, str(exc))), exc.headers)
        except OSError:
            self.close_connection = True
            log.debug("the client went away", exc_info=True)

    def do_POST(self) -> None:
        self._serve(self.server.endpoint.post)

    def do_GET(self) -> None:
        self._serve(self.server.endpoint.get)

    def do_DELETE(self) -> None:
        self._serve(self.server.endpoint.delete)

    def _not_allowed(self) -> None:
        self.close_connection = True
        self.reply(405, None, {"Allow": "GET, POST, DELETE"})

    do_PUT = do_PATCH = do_OPTIONS = do_HEAD = _not_allowed

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("%s %s", self.address_string(), format % args)


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    endpoint: _Endpoint

    def handle_error(self, request: Any, client_address: Any) -> None:
        log.exception("MCP HTTP request from %s failed", client_address)  # to the log, not to stdout


class HttpHandle:
    """A running Streamable HTTP server: ``url`` to give clients, ``close()`` to stop it (also a context
    manager)."""

    def __init__(self, httpd: _Server, endpoint: _Endpoint, url: str) -> None:
        self._httpd = httpd
        self._endpoint = endpoint
        self.url = url
        self.host, self.port = str(httpd.server_address[0]), int(httpd.server_address[1])
        self._closed = False
        self._loop_thread = threading.Thread(target=endpoint.loop.run_forever, name="mcp-http-loop", daemon=True)
        self._serve_thread = threading.Thread(
            target=httpd.serve_forever, kwargs={"poll_interval": 0.05}, name="mcp-http", daemon=True
        )
        self._loop_thread.start()
        self._serve_thread.start()

    @property
    def session_count(self) -> int:
        return len(self._endpoint.sessions)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        endpoint = self._endpoint
        endpoint.closing.set()
        self._httpd.shutdown()
        with endpoint.lock:
            sessions = list(endpoint.sessions.values())
            endpoint.sessions.clear()
        for session in sessions:
            session.end()
        self._httpd.server_close()
        endpoint.stop_loop()
        self._loop_thread.join(timeout=5)
        if not endpoint.loop.is_running():
            endpoint.loop.close()

    def __enter__(self) -> HttpHandle:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def serve_http(
    server: McpServer,
    host: str = "127.0.0.1",
    port: int = 0,
    authority: TokenAuthority | None = None,
    *,
    caller: Caller | None = None,
    path: str = "/mcp",
    allowed_origins: Iterable[str] = (),
    session_idle_s: float = 3600.0,
    keepalive_s: float = 15.0,
) -> HttpHandle:
    """Serve MCP over Streamable HTTP on ``host:port`` (port 0: a free one) in background threads.

    With an ``authority`` every request needs a bearer token it verifies, and the token names the caller (a
    ``tools/call`` with a bad token is audited as ``unverified: <claimed subject>``); without one, every request is
    ``caller`` (default: the executor's default caller), which is allowed only on a loopback address and without
    ``flight:``/``alerts:`` scopes (:class:`~agentic_core.contracts.errors.InputError`). Sessions belong to their
    caller: another caller can neither use nor end them, and a caller over its cap ends only its own oldest (with no
    authority, where all are one caller, a new session is refused instead). ``allowed_origins`` lists browser
    origins accepted besides loopback ones.
    """
    loopback = is_loopback(host)
    if not loopback and authority is None:
        raise ValueError(
            f"refusing to serve MCP on {host!r} without a token authority: anyone who can reach it could call the "
            f"tools. Set AGENTIC_UAV_TOKEN_SECRET (32+ bytes) to require bearer tokens, or bind to 127.0.0.1."
        )
    if authority is None:
        check_anonymous(caller or server.executor.default_caller)
    endpoint = _Endpoint(
        server,
        authority=authority,
        caller=caller or server.executor.default_caller,
        path=path,
        loopback=loopback,
        allowed_origins=frozenset(o.rstrip("/") for o in allowed_origins),
        session_idle_s=session_idle_s,
        keepalive_s=keepalive_s,
    )

    class Server(_Server):
        address_family = socket.AF_INET6 if ":" in host else socket.AF_INET

    try:
        httpd = Server((host.strip("[]"), port), _Handler)
    except OSError:
        endpoint.loop.close()
        raise
    httpd.endpoint = endpoint
    bound_host = str(httpd.server_address[0])
    shown = f"[{bound_host}]" if ":" in bound_host else bound_host
    return HttpHandle(httpd, endpoint, f"http://{shown}:{httpd.server_address[1]}{path}")
