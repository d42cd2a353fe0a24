"""How :class:`tools.mcp.McpClient` reaches a server: a spawned process on stdio, or Streamable HTTP with httpx.

Both run on threads and hand back :class:`concurrent.futures.Future` objects, so one client serves synchronous
code and any event loop alike. A server that dies, hangs up or cannot be reached fails the waiting requests with
:class:`ConnectionError` (retryable); a timeout is :class:`TimeoutError`; a refusal (401, 403, other 4xx) is
:class:`McpError`.

Spec facts relied on (MCP 2025-06-18 and 2025-11-25 ``basic/transports.mdx``, ``basic/lifecycle.mdx``): stdio
messages are single lines; to shut a stdio server down, close its stdin, then SIGTERM, then SIGKILL; a POSTed request
is answered with ``application/json`` or an SSE stream carrying the response (possibly after notifications and
requests of the server); a POSTed notification gets ``202``; the client sends ``Accept: application/json,
text/event-stream``, the ``Mcp-Session-Id`` it was given and ``MCP-Protocol-Version``; ``404`` for a session means
start a new one; DELETE ends a session.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import subprocess
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import IO, Any

import httpx

from agentic_core.contracts.errors import AgenticUAVError, RunFailure

from . import protocol as p

log = logging.getLogger("tools.mcp.client")

Future = concurrent.futures.Future


class McpError(RunFailure):
    """A server refused or answered what the client cannot use: a JSON-RPC error (``code``), an HTTP error
    (``status``), an unsupported protocol version. Not worth retrying as is."""

    def __init__(self, message: str, *, code: int | None = None, status: int | None = None, data: Any = None) -> None:
        super().__init__(message)
        self.code = code
        self.status = status
        self.data = data


class SessionExpired(AgenticUAVError, ConnectionError):
    """The HTTP server no longer knows our session (404): the client starts a new one and retries once."""


def _settle(future: Future[dict[str, Any]], value: dict[str, Any] | BaseException) -> None:
    try:
        if isinstance(value, BaseException):
            future.set_exception(value)
        else:
            future.set_result(value)
    except concurrent.futures.InvalidStateError:
        pass  # cancelled meanwhile: nobody waits


def _answer_server_request(message: Mapping[str, Any]) -> dict[str, Any]:
    """Our answer to a request the server sends us: we answer pings and support nothing else."""
    if message.get("method") == "ping":
        return p.success(message["id"], {})
    error = p.JsonRpcError(p.METHOD_NOT_FOUND, f"method not found: {message.get('method')}")
    return p.failure(message["id"], error)


class ClientTransport:
    """What the client needs of a transport."""

    on_message: Callable[[dict[str, Any]], None] = staticmethod(lambda message: None)
    protocol_version: str | None = None
    name = "server"

    def start(self) -> None:
        raise NotImplementedError

    def request(self, message: dict[str, Any], timeout_s: float | None = None) -> Future[dict[str, Any]]:
        """Send a request; the future holds the response message. ``timeout_s``: how long the caller waits (a
        transport that can bound its own waiting uses it)."""
        raise NotImplementedError

    def notify(self, message: dict[str, Any], *, wait: bool = True) -> None:
        raise NotImplementedError

    def new_session(self) -> None:
        """Forget the session the server ended (HTTP)."""

    def close(self) -> None:
        raise NotImplementedError


class StdioTransport(ClientTransport):
    """A server spawned as ``command``, spoken to on its stdin and stdout; its stderr goes to ``stderr`` (default:
    ours)."""

    def __init__(
        self,
        command: Sequence[str],
        *,
        env: Mapping[str, str] | None = None,
        cwd: str | None = None,
        stderr: IO[Any] | int | None = None,
    ) -> None:
        if not command:
            raise ValueError("the command to start the MCP server is empty")
        self.command = list(command)
        self.name = self.command[0]
        self.env = None if env is None else dict(env)
        self.cwd = cwd
        self.stderr = stderr
        self.process: subprocess.Popen[bytes] | None = None
        self._pending: dict[p.RequestId, Future[dict[str, Any]]] = {}
        self._lock = threading.Lock()
        self._write_lock = threading.Lock()
        self._closed: str | None = None  # why the transport is closed
        self._reader: threading.Thread | None = None

    def start(self) -> None:
        if self.process is not None:
            return
        try:
            self.process = subprocess.Popen(
                self.command,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self.stderr,
                env=self.env,
                cwd=self.cwd,
            )
        except OSError as exc:
            raise ConnectionError(f"cannot start the MCP server {self.command!r}: {exc}") from exc
        self._reader = threading.Thread(target=self._read, name="mcp-stdio-reader", daemon=True)
        self._reader.start()

    def _write(self, message: dict[str, Any]) -> None:
        process = self.process
        if process is None or process.stdin is None or self._closed:
            raise ConnectionError(f"the MCP server {self.name} is not running ({self._closed or 'not started'})")
        with self._write_lock:
            try:
                process.stdin.write((p.encode(message) + "\n").encode())
                process.stdin.flush()
            except (OSError, ValueError) as exc:
                raise ConnectionError(f"the MCP server {self.name} closed its input: {exc}") from exc

    def request(self, message: dict[str, Any], timeout_s: float | None = None) -> Future[dict[str, Any]]:
        future: Future[dict[str, Any]] = Future()
        id_ = message["id"]
        with self._lock:
            if self._closed:
                raise ConnectionError(f"the MCP server {self.name} is not running ({self._closed})")
            self._pending[id_] = future
        future.add_done_callback(lambda f: self._cancelled(id_, f))
        try:
            self._write(message)
        except ConnectionError:
            with self._lock:
                self._pending.pop(id_, None)
            raise
        return future

    def _cancelled(self, id_: p.RequestId, future: Future[dict[str, Any]]) -> None:
        with self._lock:
            self._pending.pop(id_, None)
        if future.cancelled() and not self._closed:
            reason = "the client stopped waiting"
            with contextlib.suppress(ConnectionError):
                self._write(p.notification("notifications/cancelled", {"requestId": id_, "reason": reason}))

    def notify(self, message: dict[str, Any], *, wait: bool = True) -> None:
        self._write(message)

    def _read(self) -> None:
        process = self.process
        assert process is not None and process.stdout is not None
        try:
            for line in iter(process.stdout.readline, b""):
                if not line.strip():
                    continue
                try:
                    message = p.decode(line)
                    what = p.kind(message)
                except p.JsonRpcError as exc:
                    log.warning("the MCP server %s wrote something that is not a message: %s", self.name, exc)
                    continue
                if what == "response":
                    with self._lock:
                        future = self._pending.pop(message["id"], None) if p.is_id(message["id"]) else None
                    if future is not None:
                        _settle(future, message)
                elif what == "request":
                    self._write(_answer_server_request(message))
                else:
                    self.on_message(message)
        except (OSError, ValueError, ConnectionError):
            log.debug("reading from the MCP server failed", exc_info=True)
        finally:
            self._fail_pending()

    def _fail_pending(self) -> None:
        process = self.process
        code = process.poll() if process is not None else None
        with self._lock:
            self._closed = self._closed or f"it closed its output{'' if code is None else f', exit code {code}'}"
            pending, self._pending = self._pending, {}
        for future in pending.values():
            _settle(future, ConnectionError(f"the MCP server {self.name} stopped: {self._closed}"))

    def close(self) -> None:
        process = self.process
        with self._lock:
            self._closed = self._closed or "closed by the client"
        if process is None:
            return
        if process.stdin is not None:
            with contextlib.suppress(OSError):
                process.stdin.close()
        for stop in (None, process.terminate, process.kill):
            if stop is not None:
                stop()
            try:
                process.wait(timeout=2.0)
                break
            except subprocess.TimeoutExpired:
                continue
        if self._reader is not None:
            self._reader.join(timeout=2.0)
        if process.stdout is not None:
            process.stdout.close()
        self._fail_pending()


def _sse_events(lines: Iterator[str]) -> Iterator[tuple[str, str]]:
    """(event type, data) of each event of a text/event-stream."""
    event, data = "message", list[str]()
    for line in lines:
        if not line:
            if data:
                yield event, "\n".join(data)
            event, data = "message", []
            continue
        if line.startswith(":"):
            continue
        field, _, value = line.partition(":")
        value = value[1:] if value.startswith(" ") else value
        if field == "event":
            event = value
        elif field == "data":
            data.append(value)
    if data:
        yield event, "\n".join(data)


class HttpTransport(ClientTransport):
    """A server at a Streamable HTTP ``url``; ``token`` is sent as a bearer token."""

    def __init__(
        self,
        url: str,
        *,
        token: str | None = None,
        headers: Mapping[str, str] | None = None,
        timeout_s: float | None = 30.0,
    ) -> None:
        self.url = url
        self.name = url
        base = {"Accept": "application/json, text/event-stream", **(headers or {})}
        if token:
            base["Authorization"] = f"Bearer {token}"
        self.timeout_s = timeout_s
        self.client = httpx.Client(headers=base, timeout=httpx.Timeout(30.0, read=timeout_s))
        self.session_id: str | None = None
        self._closed = False

    def start(self) -> None:
        pass

    def new_session(self) -> None:
        self.session_id = None

    def _headers(self) -> dict[str, str]:
        headers: dict[str, str] = {}
        if self.session_id:
            headers[p.SESSION_HEADER] = self.session_id
        if self.protocol_version:
            headers[p.VERSION_HEADER] = self.protocol_version
        return headers

    def request(self, message: dict[str, Any], timeout_s: float | None = None) -> Future[dict[str, Any]]:
        return self._submit(message, timeout_s)

    def notify(self, message: dict[str, Any], *, wait: bool = True) -> None:
        future = self._submit(message, self.timeout_s)
        if wait:
            future.result()

    def _submit(self, message: dict[str, Any], timeout_s: float | None) -> Future[dict[str, Any]]:
        """POST on a daemon thread of its own: a server that never answers cannot keep the process alive."""
        if self._closed:
            raise ConnectionError(f"the MCP client for {self.url} is closed")
        future: Future[dict[str, Any]] = Future()

        def post() -> None:
            if future.set_running_or_notify_cancel():
                try:
                    _settle(future, self._post(message, timeout_s))
                except BaseException as exc:
                    _settle(future, exc)

        threading.Thread(target=post, name="mcp-http-post", daemon=True).start()
        return future

    def _post(self, message: dict[str, Any], timeout_s: float | None) -> dict[str, Any]:
        sent_session = self.session_id
        timeout = httpx.Timeout(30.0, read=timeout_s if timeout_s is not None else self.timeout_s)
        try:
            with self.client.stream(
                "POST", self.url, json=message, headers=self._headers(), timeout=timeout
            ) as response:
                if message.get("method") == "initialize" and response.headers.get(p.SESSION_HEADER):
                    self.session_id = response.headers[p.SESSION_HEADER]
                return self._answer(message, response, sent_session)
        except httpx.TimeoutException as exc:
            raise TimeoutError(f"no answer from {self.url}: {exc}") from exc
        except httpx.TransportError as exc:
            raise ConnectionError(f"cannot reach the MCP server at {self.url}: {exc}") from exc

    def _answer(self, message: dict[str, Any], response: httpx.Response, sent_session: str | None) -> dict[str, Any]:
        status = response.status_code
        is_request = "id" in message and "method" in message
        kind_ = response.headers.get("content-type", "").split(";")[0].strip().lower()
        if status == 404 and sent_session is not None:
            raise SessionExpired(f"the MCP server at {self.url} ended our session")
        if status in (408, 429) or status >= 500:
            raise ConnectionError(f"the MCP server at {self.url} answered HTTP {status}")
        if status >= 400:
            body = response.read()
            error: Any = None
            if kind_ == "application/json":
                with contextlib.suppress(p.JsonRpcError):
                    reply = p.decode(body)
                    error = reply.get("error") if isinstance(reply, dict) else None
            if isinstance(error, dict) and is_request and status not in (401, 403):
                return {"jsonrpc": "2.0", "id": message["id"], "error": error}  # a JSON-RPC error at an HTTP status
            detail = error.get("message") if isinstance(error, dict) else body.decode(errors="replace")[:300]
            raise McpError(f"the MCP server at {self.url} answered HTTP {status}: {detail}", status=status)
        if not is_request:
            response.read()
            return {}
        if status == 202:
            raise McpError(f"the MCP server at {self.url} accepted a request without answering it", status=status)
        if kind_ == "application/json":
            reply = p.decode(response.read())
            if not isinstance(reply, dict):
                raise McpError(f"the MCP server at {self.url} answered a request with {type(reply).__name__}")
            return reply
        if kind_ == "text/event-stream":
            for event, data in _sse_events(response.iter_lines()):
                if event != "message" or not data.strip():
                    continue
                reply = p.decode(data)
                if isinstance(reply, dict) and "method" not in reply and reply.get("id") == message["id"]:
                    return reply
                if isinstance(reply, dict) and "method" in reply and "id" in reply:
                    self._submit(_answer_server_request(reply), self.timeout_s)
                elif isinstance(reply, dict) and "method" in reply:
                    self.on_message(reply)
            raise ConnectionError(f"the MCP server at {self.url} ended its event stream before answering")
        raise McpError(f"the MCP server at {self.url} answered with content type {kind_!r}", status=status)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        if self.session_id:
            try:
                self.client.delete(self.url, headers=self._headers(), timeout=5.0)
            except httpx.HTTPError:
                log.debug("could not end the MCP session at %s", self.url, exc_info=True)
        self.client.close()
