"""A stand-in LLM server on 127.0.0.1: a real HTTP server on a free port that speaks OpenAI's
``POST /v1/chat/completions`` and Ollama's ``POST /api/chat`` (non-streaming JSON), checks each request the way
the real servers do, records it, and answers with the replies a test scripted, in order.

Requests are checked against the wire formats: OpenAI's tool-call ``arguments`` must be JSON text, every
``tool_calls`` id must be answered by a ``role: tool`` message with its ``tool_call_id``, unknown parameters are
refused; Ollama's ``arguments`` must be an object, ``content`` a string, ``stream`` false. A request that breaks
them gets the 400 the real server would send, in its error format, and no scripted reply is used.

Like OpenAI, every answer under ``/v1`` says in ``openai-processing-ms`` how long the server worked on the request
(from its request line to its answer; in fractions of a millisecond here, where OpenAI gives whole ones).
"""

from __future__ import annotations

import base64
import binascii
import json
import re
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

OPENAI_PATH = "/v1/chat/completions"
OLLAMA_PATH = "/api/chat"
OPENAI_MODELS_PATH = "/v1/models"
OLLAMA_MODELS_PATH = "/api/tags"
PROCESSING_HEADER = "openai-processing-ms"
NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}$")
OPENAI_PARAMETERS = {
    "model", "messages", "tools", "tool_choice", "response_format", "temperature", "max_tokens",
    "max_completion_tokens", "seed", "stream", "top_p", "n", "stop", "parallel_tool_calls", "user",
}  # fmt: skip


@dataclass
class Reply:
    """One scripted answer: a status, a JSON body (or raw text), headers, and an optional stall before it."""

    status: int = 200
    body: Any = None
    text: str | None = None
    headers: dict[str, str] = field(default_factory=dict)
    stall_s: float = 0.0


@dataclass
class Received:
    """A request as the stand-in got it."""

    path: str
    headers: dict[str, str]
    body: Any


# replies in OpenAI's format ----------------------------------------------------------------------------------------
def openai_call(name: str, arguments: str | dict[str, Any], call_id: str = "call_abc123") -> dict[str, Any]:
    """A tool call as OpenAI writes it: ``arguments`` is JSON text (a dict is serialised, a string kept as is)."""
    text = arguments if isinstance(arguments, str) else json.dumps(arguments)
    return {"id": call_id, "type": "function", "function": {"name": name, "arguments": text}}


def openai_completion(
    content: str | None = None,
    *,
    tool_calls: list[dict[str, Any]] | None = None,
    finish_reason: str | None = None,
    refusal: str | None = None,
    model: str = "gpt-4o-2024-08-06",
    prompt_tokens: int = 12,
    completion_tokens: int = 5,
) -> Reply:
    message: dict[str, Any] = {"role": "assistant", "content": content, "refusal": refusal, "annotations": []}
    if tool_calls:
        message["tool_calls"] = tool_calls
    body = {
        "id": "chatcmpl-B9MBs8CjcvOU2jLn4n570S5qMJKcT",
        "object": "chat.completion",
        "created": int(time.time()),
        "model": model,
        "choices": [
            {
                "index": 0,
                "message": message,
                "logprobs": None,
                "finish_reason": finish_reason or ("tool_calls" if tool_calls else "stop"),
            }
        ],
        "usage": {
            "prompt_tokens": prompt_tokens,
            "completion_tokens": completion_tokens,
            "total_tokens": prompt_tokens + completion_tokens,
            "prompt_tokens_details": {"cached_tokens": 0, "audio_tokens": 0},
            "completion_tokens_details": {
                "reasoning_tokens": 0,
                "audio_tokens": 0,
                "accepted_prediction_tokens": 0,
                "rejected_prediction_tokens": 0,
            },
        },
        "service_tier": "default",
        "system_fingerprint": "fp_50cad350e4",
    }
    return Reply(body=body)


def openai_error(
    status: int,
    message: str,
    *,
    type: str = "invalid_request_error",
    code: str | None = None,
    param: str | None = None,
    headers: dict[str, str] | None = None,
) -> Reply:
    """An error as OpenAI sends it: ``{"error": {"message", "type", "param", "code"}}``."""
    body = {"error": {"message": message, "type": type, "param": param, "code": code}}
    return Reply(status=status, body=body, headers=headers or {})


# replies in Ollama's format ----------------------------------------------------------------------------------------
def ollama_call(name: str, arguments: Any, index: int | None = None) -> dict[str, Any]:
    """A tool call as Ollama writes it: ``arguments`` is an object, and there is no id."""
    function: dict[str, Any] = {"name": name, "arguments": arguments}
    if index is not None:
        function["index"] = index
    return {"function": function}


def ollama_chat(
    content: str = "",
    *,
    tool_calls: list[dict[str, Any]] | None = None,
    done_reason: str = "stop",
    model: str = "gemma3:4b",
    prompt_eval_count: int = 26,
    eval_count: int = 9,
) -> Reply:
    message: dict[str, Any] = {"role": "assistant", "content": content}
    if tool_calls:
        message["tool_calls"] = tool_calls
    body = {
        "model": model,
        "created_at": "2025-03-12T10:33:28.123648Z",
        "message": message,
        "done_reason": done_reason,
        "done": True,
        "total_duration": 885095291,
        "load_duration": 3753500,
        "prompt_eval_count": prompt_eval_count,
        "prompt_eval_duration": 328493000,
        "eval_count": eval_count,
        "eval_duration": 552222000,
    }
    return Reply(body=body)


def ollama_error(status: int, message: str) -> Reply:
    """An error as Ollama sends it: ``{"error": "..."}``."""
    return Reply(status=status, body={"error": message})


# request checks ----------------------------------------------------------------------------------------------------
def _check_tools(body: dict[str, Any]) -> list[str]:
    problems = []
    for tool in body.get("tools") or []:
        function = tool.get("function") if isinstance(tool, dict) else None
        if not isinstance(tool, dict) or tool.get("type") != "function" or not isinstance(function, dict):
            problems.append(f"tools: {tool!r} is not a function tool")
        elif not NAME.match(str(function.get("name", ""))):
            problems.append(f"tools: invalid function name {function.get('name')!r}")
        elif not isinstance(function.get("parameters", {}), dict):
            problems.append("tools: parameters must be an object")
    return problems


def check_openai_request(body: Any) -> list[str]:
    """What OpenAI would refuse in a chat completions request."""
    if not isinstance(body, dict):
        return ["the body must be a JSON object"]
    problems = [f"Unrecognized request argument supplied: {key}" for key in body if key not in OPENAI_PARAMETERS]
    if not isinstance(body.get("model"), str) or not body["model"]:
        problems.append("you must provide a model parameter")
    messages = body.get("messages")
    if not isinstance(messages, list) or not messages:
        return [*problems, "messages: expected a non-empty array"]
    pending: list[str] = []
    for i, message in enumerate(messages):
        role = message.get("role") if isinstance(message, dict) else None
        if role == "tool":
            call_id = message.get("tool_call_id")
            if not isinstance(call_id, str) or call_id not in pending:
                problems.append(f"messages[{i}]: role 'tool' must answer a preceding message with 'tool_calls'")
            else:
                pending.remove(call_id)
            if not isinstance(message.get("content"), str | list):
                problems.append(f"messages[{i}].content: expected a string or an array")
            continue
        if pending:
            problems.append(f"an assistant message with 'tool_calls' must be followed by tool messages for {pending}")
            pending = []
        if role == "assistant":
            if not isinstance(message.get("content"), str | list | None):
                problems.append(f"messages[{i}].content: expected a string, an array or null")
            for call in message.get("tool_calls") or []:
                function = call.get("function") or {}
                if not isinstance(call.get("id"), str) or call.get("type") != "function":
                    problems.append(f"messages[{i}].tool_calls: each call needs an id and type 'function'")
                elif not isinstance(function.get("arguments"), str):
                    problems.append(f"messages[{i}].tool_calls[].function.arguments: expected a string")
                else:
                    pending.append(call["id"])
        elif role in ("system", "user", "developer"):
            content = message.get("content")
            if isinstance(content, list):
                for part in content:
                    kind = part.get("type") if isinstance(part, dict) else None
                    if kind == "image_url" and not str(part.get("image_url", {}).get("url", "")).startswith(
                        ("data:image/", "https://")
                    ):
                        problems.append(f"messages[{i}]: image_url.url must be an https or data:image URL")
                    elif kind not in ("text", "image_url"):
                        problems.append(f"messages[{i}]: unknown content part {kind!r}")
            elif not isinstance(content, str):
                problems.append(f"messages[{i}].content: expected a string or an array")
        else:
            problems.append(f"messages[{i}].role: {role!r} is not one of system, user, assistant, tool, developer")
    if pending:
        problems.append(f"an assistant message with 'tool_calls' must be followed by tool messages for {pending}")
    problems += _check_tools(body)
    names = [t["function"]["name"] for t in body.get("tools") or [] if isinstance(t, dict) and "function" in t]
    choice = body.get("tool_choice")
    if choice is not None:
        if not names:
            problems.append("tool_choice is only allowed when tools are specified")
        elif isinstance(choice, dict):
            if choice.get("type") != "function" or choice.get("function", {}).get("name") not in names:
                problems.append(f"tool_choice: {choice!r} does not name one of the tools")
        elif choice not in ("none", "auto", "required"):
            problems.append(f"tool_choice: {choice!r} is not none, auto or required")
    response_format = body.get("response_format")
    if response_format is not None:
        kind = response_format.get("type")
        spec = response_format.get("json_schema")
        if kind == "json_schema":
            if not isinstance(spec, dict) or not NAME.match(str(spec.get("name", ""))):
                problems.append("response_format.json_schema.name: required, letters, digits, _ and - only")
            elif not isinstance(spec.get("schema"), dict) or not isinstance(spec.get("strict", False), bool):
                problems.append("response_format.json_schema: schema must be an object and strict a boolean")
        elif kind not in ("text", "json_object"):
            problems.append(f"response_format.type: {kind!r} is not text, json_object or json_schema")
    if body.get("stream"):
        problems.append("the stand-in does not stream")
    return problems


def check_ollama_request(body: Any) -> list[str]:
    """What Ollama's /api/chat would refuse (it decodes into Go structs: wrong JSON types fail)."""
    if not isinstance(body, dict):
        return ["the body must be a JSON object"]
    problems = []
    if not isinstance(body.get("model"), str) or not body["model"]:
        problems.append("model is required")
    if body.get("stream") is not False:
        problems.append("the stand-in only answers stream: false")
    for i, message in enumerate(body.get("messages") or []):
        if message.get("role") not in ("system", "user", "assistant", "tool"):
            problems.append(f"messages[{i}]: invalid role {message.get('role')!r}")
        if not isinstance(message.get("content", ""), str):
            problems.append(f"json: cannot unmarshal {type(message['content']).__name__} into Message.content string")
        for image in message.get("images") or []:
            try:
                base64.b64decode(image, validate=True)
            except (binascii.Error, TypeError):
                problems.append(f"messages[{i}].images: not base64")
        for call in message.get("tool_calls") or []:
            if not isinstance(call.get("function", {}).get("arguments"), dict):
                problems.append("json: cannot unmarshal string into ToolCallFunction.arguments (an object)")
        if "tool_name" in message and not isinstance(message["tool_name"], str):
            problems.append(f"messages[{i}].tool_name: expected a string")
    problems += _check_tools(body)
    if "format" in body and not (body["format"] == "json" or isinstance(body["format"], dict)):
        problems.append("format must be 'json' or a JSON schema")
    if not isinstance(body.get("options", {}), dict):
        problems.append("options must be an object")
    return problems


# the server --------------------------------------------------------------------------------------------------------
class _Handler(BaseHTTPRequestHandler):
    protocol_version = "HTTP/1.1"
    disable_nagle_algorithm = True  # as real servers do: a reply on a kept-alive connection is not held back ~40 ms
    server: _Server

    def log_message(self, format: str, *args: Any) -> None:  # quiet
        pass

    def parse_request(self) -> bool:
        self.started = time.perf_counter()  # the request line is in: from here on the server is at work
        return super().parse_request()

    def do_POST(self) -> None:
        standin = self.server.standin
        raw = self.rfile.read(int(self.headers.get("Content-Length") or 0))
        try:
            body: Any = json.loads(raw)
        except ValueError:
            body = raw.decode("utf-8", "replace")
        standin.record(Received(self.path, {k.lower(): v for k, v in self.headers.items()}, body))
        self._answer(standin.answer(self.path, body, self.headers.get("Authorization")))

    def do_GET(self) -> None:
        """The model lists a client may probe (OpenAI's ``GET /v1/models``, Ollama's ``GET /api/tags``)."""
        standin = self.server.standin
        standin.note_probe(self.path)
        self._answer(standin.models(self.path, self.headers.get("Authorization")))

    def _answer(self, reply: Reply) -> None:
        if reply.stall_s:
            self.server.standin.released.wait(reply.stall_s)
        payload = (reply.text if reply.text is not None else json.dumps(reply.body)).encode()
        try:
            self.send_response(reply.status)
            content_type = "text/plain; charset=utf-8" if reply.text is not None else "application/json"
            self.send_header("Content-Type", content_type)
            self.send_header("Content-Length", str(len(payload)))
            headers = dict(reply.headers)
            if self.path.startswith("/v1/") and PROCESSING_HEADER not in {k.lower() for k in headers}:
                # as OpenAI says how long it worked on a request (in whole ms; finer here, for the benchmark)
                headers[PROCESSING_HEADER] = f"{1000 * (time.perf_counter() - self.started):.3f}"
            for name, value in headers.items():
                self.send_header(name, value)
            self.end_headers()
            self.wfile.write(payload)
        except (BrokenPipeError, ConnectionResetError):
            pass  # the client gave up waiting (a timeout test)


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    block_on_close = False
    standin: StandIn


class StandIn:
    """The stand-in server; use as a context manager, or :meth:`start` and :meth:`stop`.

    ``key``, when set, is the API key it requires: a request without ``Authorization: Bearer KEY`` gets OpenAI's
    401, which (unlike OpenAI, to test redaction) quotes the whole header value it got.
    """

    def __init__(self, *, key: str | None = None, responder: Callable[[str, Any], Reply] | None = None) -> None:
        self.key = key
        self.responder = responder
        """Answers (path, body) once the scripted replies run out: a stand-in model that reads the request."""
        self.received: list[Received] = []
        self.probes: list[str] = []
        """Paths of the GETs clients probed with (kept apart from the chat requests in ``received``)."""
        self.released = threading.Event()
        self._replies: list[Reply] = []
        self._lock = threading.Lock()
        self._server: _Server | None = None
        self._thread: threading.Thread | None = None

    @property
    def url(self) -> str:
        assert self._server is not None, "the stand-in is not running"
        host, port = self._server.server_address[:2]
        return f"http://{host!s}:{port}"

    def script(self, *replies: Reply) -> StandIn:
        with self._lock:
            self._replies.extend(replies)
        return self

    def record(self, request: Received) -> None:
        with self._lock:
            self.received.append(request)

    def note_probe(self, path: str) -> None:
        with self._lock:
            self.probes.append(path)

    def models(self, path: str, authorization: str | None) -> Reply:
        if path == OPENAI_MODELS_PATH:
            if self.key is not None and authorization != f"Bearer {self.key}":
                return openai_error(401, f"Incorrect API key provided: {authorization}.", code="invalid_api_key")
            return Reply(body={"object": "list", "data": [{"id": "gpt-4o", "object": "model", "owned_by": "system"}]})
        if path == OLLAMA_MODELS_PATH:
            return Reply(body={"models": [{"name": "gemma3:4b", "model": "gemma3:4b", "size": 3338801804}]})
        return Reply(status=404, text="404 page not found")

    def bodies(self) -> list[Any]:
        with self._lock:
            return [request.body for request in self.received]

    def answer(self, path: str, body: Any, authorization: str | None) -> Reply:
        if path == OPENAI_PATH:
            if self.key is not None and authorization != f"Bearer {self.key}":
                return openai_error(401, f"Incorrect API key provided: {authorization}.", code="invalid_api_key")
            problems = check_openai_request(body)
            if problems:
                return openai_error(400, "; ".join(problems), code="invalid_request")
        elif path == OLLAMA_PATH:
            problems = check_ollama_request(body)
            if problems:
                return ollama_error(400, "; ".join(problems))
        else:
            return Reply(status=404, text="404 page not found")
        with self._lock:
            if self._replies:
                return self._replies.pop(0)
        if self.responder is not None:
            return self.responder(path, body)
        return Reply(status=500, body={"error": "the stand-in has no scripted reply left"})

    def start(self) -> StandIn:
        server = _Server(("127.0.0.1", 0), _Handler)
        server.standin = self
        self._server = server
        self._thread = threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.05}, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self.released.set()  # stalled replies end now
        if self._server is not None:
            self._server.shutdown()
            self._server.server_close()
        if self._thread is not None:
            self._thread.join(timeout=5)
        self._server = self._thread = None

    def __enter__(self) -> StandIn:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.stop()
