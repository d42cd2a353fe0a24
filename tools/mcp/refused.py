"""Audit records for ``tools/call`` requests refused before any session: a bad or forged bearer token.

The HTTP transport answers such a request ``401`` and never runs it; the audit log still shows the attempt, under
the subject the token claims (``unverified: <subject>``), never under the server's default caller. Arguments are
redacted as for any call and dropped past ``MAX_ARGS_BYTES``; at most ``MAX_RECORDS`` calls of one body are kept.

>>> from tools import MemoryAuditLog, ToolExecutor, ToolRegistry
>>> executor = ToolExecutor(ToolRegistry(), audit=MemoryAuditLog())
>>> body = b'{"jsonrpc":"2.0","id":1,"method":"tools/call","params":{"name":"flight.land","arguments":{}}}'
>>> audit_refused(executor, body, "not.a-jwt.token", "invalid token: forged")
1
>>> record = executor.audit.records[-1]
>>> record.caller, record.tool, record.status, record.error
('unverified: ?', 'flight.land', 'denied', 'invalid token: forged')
"""

from __future__ import annotations

import json
import logging
import os
from datetime import UTC, datetime
from typing import Any

from ..audit import AuditRecord, redact
from ..auth import unverified_caller
from ..executor import ToolExecutor
from . import protocol as p

log = logging.getLogger("tools.mcp.http")

MAX_RECORDS = 16
MAX_ARGS_BYTES = 4096
MAX_NAME_CHARS = 128


def refused_calls(body: bytes) -> list[tuple[str, Any]]:
    """The ``(tool name, arguments)`` of the ``tools/call`` requests in a body (one message or a batch)."""
    try:
        message = p.decode(body)
    except p.JsonRpcError:
        return []
    messages = message if isinstance(message, list) else [message]
    calls: list[tuple[str, Any]] = []
    for item in messages[:MAX_RECORDS]:
        if not isinstance(item, dict) or item.get("method") != "tools/call":
            continue
        params = item.get("params")
        params = params if isinstance(params, dict) else {}
        name = params.get("name")
        shown = "".join(c for c in name[:MAX_NAME_CHARS] if c.isprintable()) if isinstance(name, str) else "?"
        calls.append((shown or "?", params.get("arguments", {})))
    return calls


def audit_refused(executor: ToolExecutor, body: bytes, token: str, reason: str) -> int:
    """Write a ``denied`` record for each ``tools/call`` in ``body`` refused for its ``token``; how many."""
    caller = unverified_caller(token).id
    written = 0
    for name, args in refused_calls(body):
        entry = executor.registry.entry(name)
        kept = redact(args, entry.spec.sensitive_args if entry is not None else frozenset())
        size = len(json.dumps(kept, default=str))
        if size > MAX_ARGS_BYTES:
            kept = {"[omitted]": f"{size} bytes of arguments"}
        record = AuditRecord(
            time=datetime.now(UTC).isoformat(timespec="microseconds"),
            call_id=os.urandom(8).hex(),
            caller=caller,
            tool=name,
            args=kept,
            status="denied",
            latency_s=0.0,
            attempts=0,
            cached=False,
            error=reason,
            stages=["authorize:failed"],
        )
        try:
            executor.audit.write(record)
            written += 1
        except Exception:
            log.warning("could not audit a refused call of %s", name, exc_info=True)
    return written
