"""JSON-RPC 2.0 framing and the MCP facts the server and the client share: error codes, protocol versions,
message shapes, and how a tool result is written as MCP content and read back.

Spec facts relied on (MCP revisions 2025-06-18 and 2025-11-25, read in modelcontextprotocol/modelcontextprotocol
``docs/specification/<rev>/basic/{lifecycle,transports}.mdx``, ``server/tools.mdx`` and
``server/utilities/pagination.mdx``; the installed ``mcp_types.version`` lists the same handshake versions):

- version negotiation: a server that supports the client's ``protocolVersion`` answers with it, else with another
  version it supports, preferably its latest;
- ``2025-06-18`` removed JSON-RPC batching (its changelog, PR #416); ``2025-03-26`` still allowed batches and the
  ``initialize`` request never in one;
- request ids are strings or integers, never null; notifications get no answer;
- an unknown tool and a malformed ``tools/call`` are protocol errors (``-32602``); a tool that fails, including
  on bad input, is a result with ``isError: true``; an invalid list cursor is ``-32602``;
- a tool result holds ``content`` (text items here) and, for a tool with an output schema, ``structuredContent``
  that conforms to it, with the same JSON also as text for older clients.

>>> decode('{"jsonrpc": "2.0", "id": 0, "method": "ping"}')["id"]
0
>>> negotiate("2025-06-18"), negotiate("1999-01-01")
('2025-06-18', '2025-11-25')
>>> content_text([{"type": "text", "text": "a"}, {"type": "image", "data": "AAAA", "mimeType": "image/png"}])
'a\\n[image: image/png, 3 bytes]'
"""

from __future__ import annotations

import base64
import binascii
import json
from collections.abc import Mapping
from typing import Any, Literal, TypeGuard

from agentic_core.contracts import json_depth as bounded_json
from agentic_core.contracts.errors import AgenticUAVError

from ..result import ToolResult
from ..security import wrap_untrusted

PARSE_ERROR = -32700
INVALID_REQUEST = -32600
METHOD_NOT_FOUND = -32601
INVALID_PARAMS = -32602
INTERNAL_ERROR = -32603

PROTOCOL_VERSIONS: tuple[str, ...] = ("2025-11-25", "2025-06-18", "2025-03-26")
"""The revisions we speak, newest first."""
LATEST_VERSION = PROTOCOL_VERSIONS[0]
BATCHING_VERSIONS = frozenset({"2025-03-26"})
"""Revisions that allow JSON-RPC batches (2025-06-18 removed them)."""

SESSION_HEADER = "Mcp-Session-Id"
VERSION_HEADER = "MCP-Protocol-Version"

MessageKind = Literal["request", "notification", "response"]
RequestId = str | int


class JsonRpcError(AgenticUAVError):
    """A JSON-RPC error to answer with (server side) or that a server answered (client side)."""

    def __init__(self, code: int, message: str, data: Any = None) -> None:
        super().__init__(message)
        self.code = code
        self.message = message
        self.data = data

    def to_dict(self) -> dict[str, Any]:
        error: dict[str, Any] = {"code": self.code, "message": self.message}
        if self.data is not None:
            error["data"] = self.data
        return error

    def __str__(self) -> str:
        return f"{self.message} (JSON-RPC error {self.code})"


def negotiate(requested: object) -> str:
    """The version to answer an ``initialize`` with: the client's when we speak it, else our latest."""
    return requested if isinstance(requested, str) and requested in PROTOCOL_VERSIONS else LATEST_VERSION


def encode(message: Any) -> str:
    """One message as compact JSON on one line (``json`` escapes newlines inside strings)."""
    return json.dumps(message, ensure_ascii=False, separators=(",", ":"), default=str)


def decode(text: str | bytes) -> Any:
    """A message's JSON; :class:`JsonRpcError` ``-32700`` when it is not JSON."""
    try:
        return bounded_json.loads(text)
    except (ValueError, UnicodeDecodeError) as exc:
        raise JsonRpcError(PARSE_ERROR, f"parse error: {exc}") from None


def is_id(value: object) -> TypeGuard[RequestId]:
    return isinstance(value, str) or (isinstance(value, int) and not isinstance(value, bool))


def message_id(message: object) -> RequestId | None:
    """The id to answer a message with: its own when valid, else null."""
    if isinstance(message, Mapping):
        value = message.get("id")
        if is_id(value):
            return value
    return None


def kind(message: object) -> MessageKind:
    """What a message is; :class:`JsonRpcError` ``-32600`` when it is none of a request, a notification or a
    response."""
    if not isinstance(message, Mapping) or message.get("jsonrpc") != "2.0":
        raise JsonRpcError(INVALID_REQUEST, "invalid request: expected a JSON-RPC 2.0 object")
    if "method" in message:
        if not isinstance(message["method"], str):
            raise JsonRpcError(INVALID_REQUEST, "invalid request: 'method' must be a string")
        if "params" in message and not isinstance(message["params"], Mapping | list):
            raise JsonRpcError(INVALID_REQUEST, "invalid request: 'params' must be structured (an object)")
        if "id" not in message:
            return "notification"
        if not is_id(message["id"]):
            raise JsonRpcError(INVALID_REQUEST, "invalid request: 'id' must be a string or an integer")
        return "request"
    if "id" in message and ("result" in message) != ("error" in message):
        return "response"
    raise JsonRpcError(INVALID_REQUEST, "invalid request: neither a request, a notification nor a response")


def request(id: RequestId, method: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
    message: dict[str, Any] = {"jsonrpc": "2.0", "id": id, "method": method}
    if params is not None:
        message["params"] = dict(params)
    return message


def notification(method: str, params: Mapping[str, Any] | None = None) -> dict[str, Any]:
    message: dict[str, Any] = {"jsonrpc": "2.0", "method": method}
    if params is not None:
        message["params"] = dict(params)
    return message


def success(id: RequestId, result: Mapping[str, Any]) -> dict[str, Any]:
    return {"jsonrpc": "2.0", "id": id, "result": dict(result)}


def failure(id: RequestId | None, error: JsonRpcError) -> dict[str, Any]:
    return {"jsonrpc": "2.0", "id": id, "error": error.to_dict()}


def unwrap(response: Mapping[str, Any]) -> dict[str, Any]:
    """A response's result; :class:`JsonRpcError` for an error response or a malformed one."""
    if "error" in response:
        error = response["error"]
        if isinstance(error, Mapping) and isinstance(error.get("code"), int):
            raise JsonRpcError(error["code"], str(error.get("message", "")), error.get("data"))
        raise JsonRpcError(INTERNAL_ERROR, f"malformed error response: {error!r}")
    result = response.get("result")
    if not isinstance(result, Mapping):
        raise JsonRpcError(INTERNAL_ERROR, f"malformed response: 'result' is not an object: {result!r}")
    return dict(result)


# tool results ---------------------------------------------------------------------------------------------------
def output_text(output: Any) -> str:
    """A tool's output as text: a string as it is, anything else as JSON."""
    return output if isinstance(output, str) else json.dumps(output, ensure_ascii=False, default=str)


def call_result(result: ToolResult, *, structured: bool) -> dict[str, Any]:
    """A :class:`ToolResult` as an MCP ``CallToolResult``. ``structured``: the tool declares an object output
    schema, so an object output is also sent as ``structuredContent``. A refused or failed call is a result with
    ``isError: true`` whose text names the status and the error. Output from outside is marked in ``_meta``, and
    output the injection guard flagged is fenced with :func:`tools.security.wrap_untrusted`."""
    if not result.ok:
        text = f"{result.status}: {result.error or 'the tool failed'}"
        if result.retry_after_s is not None:
            text += f" (retry in {result.retry_after_s:.3g} s)"
        return {"content": [{"type": "text", "text": text}], "isError": True}
    text = output_text(result.output)
    if result.injection is not None:  # fenced, so the client's model can quote it without obeying it
        text = wrap_untrusted(text, source=f"the output of the tool {result.tool}")
    answer: dict[str, Any] = {"content": [{"type": "text", "text": text}], "isError": False}
    if structured and isinstance(result.output, dict):
        answer["structuredContent"] = result.output
    if result.untrusted:
        meta: dict[str, Any] = {"untrusted": True}
        if result.injection is not None:
            meta["injection"] = {
                "score": result.injection.score,
                "kinds": sorted({f.kind for f in result.injection.findings}),
            }
        answer["_meta"] = {"agentic-uavs/guard": meta}
    return answer


def _size(data: object) -> str:
    try:
        return f"{len(base64.b64decode(str(data), validate=True))} bytes"
    except (binascii.Error, ValueError):
        return "undecodable data"


def describe_item(item: object) -> str:
    """One content item as text: text as it is, anything else described in brackets."""
    if not isinstance(item, Mapping):
        return f"[unknown content: {item!r}]"
    kind_ = item.get("type")
    if kind_ == "text":
        return str(item.get("text", ""))
    if kind_ in ("image", "audio"):
        return f"[{kind_}: {item.get('mimeType', 'unknown type')}, {_size(item.get('data', ''))}]"
    if kind_ == "resource_link":
        return f"[resource link: {item.get('uri', '?')}]"
    if kind_ == "resource":
        resource = item.get("resource")
        if isinstance(resource, Mapping):
            if "text" in resource:
                return str(resource["text"])
            return f"[resource: {resource.get('uri', '?')}, {resource.get('mimeType', 'binary')}]"
    return f"[{kind_ or 'unknown'} content]"


def content_text(content: object) -> str:
    """The text of a ``content`` list: text items joined by newlines, other items described."""
    if not isinstance(content, list):
        return ""
    return "\n".join(describe_item(item) for item in content)
