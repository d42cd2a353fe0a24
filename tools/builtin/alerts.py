"""``alerts.send_email``, ``alerts.webhook`` and ``alerts.notify`` (the mission DSL's ``action: notify``).

``notify`` routes one alert to a channel: ``email`` (to ``to`` or the configured recipients; the outbox when no
mail server is set), ``webhook`` (the configured URL, else the outbox) or ``log`` (a line of
``outbox_dir/notifications.jsonl``). Its ``attach`` holds file paths, or names of artefacts the mission runtime has
not produced as files (``snapshot``, ``position``, ``world_model``): files inside ``attachment_dirs`` are attached,
other names (and files outside those folders) are listed in
the message and the receipt as not available, never an error.

>>> import tempfile
>>> config = BuiltinConfig(outbox_dir=Path(tempfile.mkdtemp()))
>>> receipt = notify(config, "Collapsed pilgrim", "Motionless for 40 s.", channel="log", attach=["snapshot"])
>>> receipt.delivered_via, receipt.unavailable, Path(receipt.path).name
('log', ['snapshot'], 'notifications.jsonl')
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, Field

from ..function import spec_from_function
from ..spec import RetrySpec, ToolContext, ToolSpec, declared_transient
from .config import BuiltinConfig, may_attach
from .mail import EmailReceipt, keyed_message_id, send_email, send_files
from .outbox import append_line, now_iso
from .webhook import WebhookReceipt, post_webhook

Channel = Literal["email", "webhook", "log"]
NOTIFY = "alerts.notify"


class NotifyReceipt(BaseModel):
    """What became of an alert sent with ``alerts.notify``."""

    channel: Channel
    delivered_via: Literal["smtp", "outbox", "webhook", "log"]
    message_id: str | None = None
    path: str | None = Field(default=None, description="the outbox file written (.eml, .json or notifications.jsonl)")
    status: int | None = Field(default=None, description="the webhook's HTTP status")
    recipients: list[str] = Field(default_factory=list)
    attached: list[str] = Field(default_factory=list, description="the files attached")
    unavailable: list[str] = Field(default_factory=list, description="attachments named but not available as files")


def recipients_of(to: Sequence[str] | str | None) -> list[str]:
    """``to`` as a list: a string may hold several addresses separated by commas or semicolons."""
    if to is None:
        return []
    items = [to] if isinstance(to, str) else list(to)
    return [a.strip() for item in items for a in item.replace(";", ",").split(",") if a.strip()]


def notify(
    config: BuiltinConfig,
    subject: str,
    body: str,
    channel: Channel = "email",
    to: Sequence[str] | str | None = None,
    attach: Sequence[str] = (),
    reported_by: str | None = None,
    keep_as: str | None = None,
    idempotency_key: str | None = None,
) -> NotifyReceipt:
    """Send one alert on ``channel``; see the module docstring. ``keep_as`` names the outbox copy kept when
    delivery fails (the call id). ``idempotency_key`` makes the e-mail's Message-ID (the same for every re-run)
    and the webhook's ``Idempotency-Key`` header, so a receiver that dedupes sees one alert."""
    files = [item for item in attach if Path(item).expanduser().is_file() and may_attach(config, item)]
    unavailable = [item for item in attach if item not in files]
    recipients = recipients_of(to) or list(config.alert_recipients)
    if channel == "email":
        text = body + (f"\n\nNot available: {', '.join(unavailable)}" if unavailable else "")
        message_id = None if idempotency_key is None else keyed_message_id(config, NOTIFY, idempotency_key)
        paths = [Path(f).expanduser() for f in files]
        mail = send_files(config, recipients, subject, text, paths, keep_as=keep_as, message_id=message_id)
        return NotifyReceipt(
            channel=channel,
            delivered_via=mail.delivered_via,
            message_id=mail.message_id,
            path=mail.eml_path,
            recipients=mail.recipients,
            attached=files,
            unavailable=unavailable,
        )
    record: dict[str, Any] = {
        "time": now_iso(),
        "subject": subject,
        "body": body,
        "to": recipients,
        "attachments": files,
        "unavailable": unavailable,
        "reported_by": reported_by,
    }
    if channel == "webhook":
        hook = post_webhook(config, record, keep_as=keep_as, idempotency_key=idempotency_key)
        return NotifyReceipt(
            channel=channel,
            delivered_via=hook.delivered_via,
            path=hook.path,
            status=hook.status,
            recipients=recipients,
            attached=files,
            unavailable=unavailable,
        )
    path = append_line(config.outbox_dir, record)
    return NotifyReceipt(
        channel=channel,
        delivered_via="log",
        path=str(path),
        recipients=recipients,
        attached=files,
        unavailable=unavailable,
    )


def alert_tools(config: BuiltinConfig) -> list[ToolSpec]:
    """``alerts.send_email``, ``alerts.webhook`` and ``alerts.notify`` bound to ``config``."""
    retry = RetrySpec(attempts=3, retry_if=declared_transient)
    options: dict[str, Any] = {
        "scopes": ["alerts:send"],
        "rate_limit": "5/s",
        "retry": retry,
        "timeout_s": config.http_timeout_s * 6 + 5,  # SMTP takes several round trips, each bounded by the timeout
        "side_effects": True,
    }

    def email(
        to: Annotated[list[str], Field(min_length=1, max_length=100)],
        subject: Annotated[str, Field(max_length=900)],
        body: str,
        attachments: tuple[str, ...] = (),
        *,
        context: ToolContext,
    ) -> EmailReceipt:
        """Send an e-mail (through the configured mail server, else into the outbox as an .eml file).

        Args:
            to: recipient addresses
            subject: the subject line
            body: the plain-text message
            attachments: paths of files to attach, e.g. an annotated PNG
        """
        key = context.idempotency_key
        message_id = None if key is None else keyed_message_id(config, "alerts.send_email", key)
        return send_email(config, to, subject, body, attachments, keep_as=context.call_id, message_id=message_id)

    def webhook(payload: dict[str, Any], url: str | None = None, *, context: ToolContext) -> WebhookReceipt:
        """POST a JSON payload to a webhook (the configured one when no URL is given, else into the outbox).

        Args:
            payload: the JSON object to send
            url: an http(s) URL; defaults to the configured webhook
        """
        return post_webhook(config, payload, url, keep_as=context.call_id, idempotency_key=context.idempotency_key)

    def notify_tool(
        subject: str,
        body: str,
        channel: Channel = "email",
        to: list[str] | str | None = None,
        attach: tuple[str, ...] = (),
        *,
        context: ToolContext,
    ) -> NotifyReceipt:
        """Send an alert by e-mail, webhook or the notification log.

        Args:
            subject: a one-line summary
            body: the message
            channel: email, webhook or log
            to: recipient addresses (a list or a comma-separated string); defaults to the configured recipients
            attach: file paths, or artefact names such as snapshot, position, world_model
        """
        return notify(
            config,
            subject,
            body,
            channel,
            to,
            attach,
            reported_by=context.caller.id,
            keep_as=context.call_id,
            idempotency_key=context.idempotency_key,
        )

    return [
        spec_from_function(email, name="alerts.send_email", **options),
        spec_from_function(webhook, name="alerts.webhook", untrusted_output=True, **options),
        spec_from_function(notify_tool, name=NOTIFY, **options),
    ]


__all__ = ["NotifyReceipt", "alert_tools", "notify", "recipients_of"]
