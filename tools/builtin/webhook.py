"""Webhook alerts: a JSON payload POSTed to a URL, or kept in the outbox when no URL is configured.

Retries must never post twice, so only failures where the endpoint cannot have acted are transient: no connection
(refused, unreachable, connect timeout) and HTTP 429 or 503 (the endpoint says it did not process the request).
A link that breaks after the request went out, and every other error status, is a :class:`ToolError`.

>>> import json, tempfile
>>> from pathlib import Path
>>> config = BuiltinConfig(outbox_dir=Path(tempfile.mkdtemp()))
>>> receipt = post_webhook(config, {"event": "collapse", "lat": 21.41})
>>> receipt.delivered_via, json.loads(Path(receipt.path).read_text())["payload"]["event"]
('outbox', 'collapse')
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import replace
from typing import Any, Literal
from urllib.parse import urlsplit

import httpx
from pydantic import BaseModel, Field

from ..egress import fenced, guarded_client
from ..errors import ToolError, TransientToolError
from ..idempotency import header_value
from .allowlist import HOST_SETTINGS, check_webhook_allowed, webhook_hosts
from .config import BuiltinConfig, egress_policy
from .outbox import discard_undelivered, keep_undelivered, now_iso, write_file

EXCERPT_CHARS = 500


class WebhookReceipt(BaseModel):
    """What became of a webhook payload."""

    delivered_via: Literal["webhook", "outbox"]
    status: int | None = Field(default=None, description="the endpoint's HTTP status; null when kept in the outbox")
    endpoint: str | None = Field(default=None, description="scheme://host of the URL (its path may hold a secret)")
    path: str | None = Field(default=None, description="the .json written to the outbox")
    response_excerpt: str | None = Field(
        default=None, description="the start of the endpoint's answer, fenced: outside text"
    )


def endpoint_of(url: str) -> str:
    """``scheme://host[:port]`` of a URL: what may be shown of a webhook URL (Slack-style URLs embed a token)."""
    parts = urlsplit(url)
    return f"{parts.scheme}://{parts.hostname or ''}{f':{parts.port}' if parts.port else ''}"


def post_webhook(
    config: BuiltinConfig,
    payload: Mapping[str, Any],
    url: str | None = None,
    keep_as: str | None = None,
    idempotency_key: str | None = None,
) -> WebhookReceipt:
    """POST ``payload`` as JSON to ``url`` or ``config.webhook_url``; with neither, write it to the outbox. When the
    POST fails in any way, a copy goes to the outbox too (named by ``keep_as``, the call id, so the retries of one
    call keep one copy, removed once a retry delivers) and the error says where. ``idempotency_key`` is sent as the
    ``Idempotency-Key`` header, so an endpoint that honours it acts once for every re-run of the action."""
    body = json.dumps(payload, ensure_ascii=False, default=str)
    target = url or config.webhook_url
    record = {"time": now_iso(), "url": None, "payload": json.loads(body)}
    if not target:
        path = write_file(config.outbox_dir, ".json", json.dumps(record, ensure_ascii=False, indent=2).encode())
        return WebhookReceipt(delivered_via="outbox", path=str(path))
    check_webhook_allowed(config, target)  # before anything is kept: a refused payload is not an alert
    try:
        receipt = _post(config, target, body, idempotency_key)
    except Exception as exc:
        record["url"] = endpoint_of(target)  # not the full URL: it may carry a token
        data = json.dumps(record, ensure_ascii=False, indent=2).encode()
        path = keep_undelivered(config.outbox_dir, keep_as, ".json", data)
        kept = type(exc) if isinstance(exc, ToolError | TransientToolError) else ToolError
        raise kept(f"{exc} (a copy was kept in {path})") from None
    discard_undelivered(config.outbox_dir, keep_as, ".json")
    return receipt


def _post(config: BuiltinConfig, target: str, body: str, idempotency_key: str | None = None) -> WebhookReceipt:
    endpoint = endpoint_of(target)
    if urlsplit(target).scheme not in ("http", "https") or not urlsplit(target).hostname:
        raise ToolError(f"the webhook URL must be http(s)://host/...; got one starting {target[:12]!r}")
    headers = {"Content-Type": "application/json"}
    if idempotency_key is not None:
        headers["Idempotency-Key"] = header_value(idempotency_key)
    try:
        policy = replace(egress_policy(config), hosts=webhook_hosts(config), hosts_setting=HOST_SETTINGS)
        with guarded_client(policy, config.http_timeout_s) as client:  # a redirect must stay on an allowed host
            response = client.post(target, content=body.encode(), headers=headers)
    except (httpx.ConnectError, httpx.ConnectTimeout, httpx.PoolTimeout) as exc:
        raise TransientToolError(f"cannot reach the webhook {endpoint} (nothing was sent): {exc}") from None
    except httpx.TransportError as exc:
        raise ToolError(
            f"the link to the webhook {endpoint} broke after the payload went out ({type(exc).__name__}: {exc}); "
            "it may have arrived, so it was not sent again"
        ) from None
    excerpt = fenced(response.text, EXCERPT_CHARS) if response.text else ""
    status = response.status_code
    if status in (429, 503):
        raise TransientToolError(f"the webhook {endpoint} is busy (HTTP {status}); it did not take the payload")
    if status >= 300:
        raise ToolError(
            f"the webhook {endpoint} answered HTTP {status} {response.reason_phrase}: {fenced(response.text, 200)}"
        )
    return WebhookReceipt(delivered_via="webhook", status=status, endpoint=endpoint, response_excerpt=excerpt or None)


__all__ = ["WebhookReceipt", "endpoint_of", "post_webhook"]
