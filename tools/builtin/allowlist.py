"""Where alerts may go: e-mail recipients and webhook hosts come from an allowlist in configuration.

A model talked into mailing a casualty's position to an arbitrary address, or posting it to an arbitrary URL, is
refused before anything is sent, with a reason it sees (a :class:`DestinationRefused`, audited like any result).
Recipients: ``AGENTIC_UAV_ALERT_RECIPIENTS`` (the medical team) and ``AGENTIC_UAV_ALERT_ALLOW`` (addresses, or
``@domain`` for every address there); checked whenever a message would leave the machine (a mail server is set;
the outbox is this machine's own folder). Webhook hosts: the host of ``AGENTIC_UAV_WEBHOOK_URL`` and
``AGENTIC_UAV_WEBHOOK_ALLOW``; checked on every request, redirects included, by the egress policy
(:mod:`tools.egress`), which still refuses internal addresses unless ``AGENTIC_UAV_EGRESS_ALLOW`` lets them.

>>> config = BuiltinConfig(smtp_host="mail.example", alert_recipients=["medic@team.example"])
>>> check_recipients_allowed(config, ["Medic <MEDIC@team.example>"])
>>> try:
...     check_recipients_allowed(config, ["medic@team.example", "drop@evil.example"])
... except DestinationRefused as exc:
...     print(str(exc).split(" (")[0])
refused: drop@evil.example is not on the alert allowlist
>>> webhook_hosts(BuiltinConfig(webhook_url="https://hooks.example/T0KEN"))
('hooks.example',)
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from email.utils import parseaddr
from typing import Any
from urllib.parse import urlsplit

from ..errors import ToolError
from .config import BuiltinConfig

RECIPIENT_SETTINGS = "AGENTIC_UAV_ALERT_RECIPIENTS, AGENTIC_UAV_ALERT_ALLOW"
HOST_SETTINGS = "AGENTIC_UAV_WEBHOOK_URL, AGENTIC_UAV_WEBHOOK_ALLOW"
MAIL_TOOLS = frozenset({"alerts.notify", "alerts.send_email"})


class DestinationRefused(ToolError):
    """An alert addressed somewhere the configuration does not allow; nothing was sent."""


def _bare(address: str) -> str:
    return parseaddr(address)[1].strip().lower()


def allowed_recipients(config: BuiltinConfig) -> frozenset[str]:
    """The allowlist's entries, lower-cased: bare addresses and ``@domain`` entries."""
    entries = [*config.alert_recipients, *config.alert_allow]
    return frozenset(e.strip().lower() if e.strip().startswith("@") else _bare(e) for e in entries if e.strip())


def recipient_allowed(allowed: frozenset[str], address: str) -> bool:
    """Whether the bare ``address`` is on ``allowed`` (exactly, or its one domain as ``@domain``)."""
    bare = _bare(address)
    if not bare:
        return False
    if bare in allowed:
        return True
    local, _, domain = bare.rpartition("@")
    return bool(local) and "@" not in local and f"@{domain}" in allowed


def mail_leaves(config: BuiltinConfig) -> bool:
    """Whether mail goes out (a mail server is set) rather than into the outbox."""
    return bool(config.smtp_host)


def refused_recipients(config: BuiltinConfig, to: Iterable[str]) -> list[str]:
    """The addresses of ``to`` the allowlist refuses (none when mail stays in the outbox)."""
    if not mail_leaves(config):
        return []
    allowed = allowed_recipients(config)
    return [_bare(a) or a for a in to if not recipient_allowed(allowed, a)]


def check_recipients_allowed(config: BuiltinConfig, to: Sequence[str]) -> None:
    """Nothing, or :class:`DestinationRefused` naming every address of ``to`` not on the allowlist."""
    refused = refused_recipients(config, to)
    if refused:
        raise DestinationRefused(
            f"refused: {', '.join(refused)} {'is' if len(refused) == 1 else 'are'} not on the alert allowlist "
            f"({RECIPIENT_SETTINGS}); nothing was sent"
        )


def host_of(url: str) -> str:
    """The lower-cased host of ``url`` (empty when it has none)."""
    try:
        return (urlsplit(url).hostname or "").rstrip(".").lower()
    except ValueError:
        return ""


def webhook_hosts(config: BuiltinConfig) -> tuple[str, ...]:
    """The hosts a webhook may reach: the configured webhook's, and ``webhook_allow``."""
    hosts = [host_of(config.webhook_url)] if config.webhook_url else []
    hosts += [h.strip().rstrip(".").lower() for h in config.webhook_allow]
    return tuple(dict.fromkeys(h for h in hosts if h))


def check_webhook_allowed(config: BuiltinConfig, url: str) -> None:
    """Nothing, or :class:`DestinationRefused` when the host of ``url`` is not a webhook host."""
    host = host_of(url)
    if urlsplit(url).scheme not in ("http", "https") or not host:
        raise DestinationRefused(f"refused: the webhook URL must be http(s)://host/...; got {url[:12]!r}...")
    if host not in webhook_hosts(config):
        raise DestinationRefused(
            f"refused: the webhook host {host or url[:40]!r} is not on the webhook allowlist ({HOST_SETTINGS}); "
            "nothing was sent"
        )


def _recipients(to: Any) -> list[str]:
    items = [to] if isinstance(to, str) else list(to) if isinstance(to, list | tuple) else []
    return [a.strip() for item in items if isinstance(item, str) for a in item.replace(";", ",").split(",") if a]


def destination_problems(config: BuiltinConfig, tool: str, args: Mapping[str, Any]) -> list[str]:
    """What the allowlists refuse of one call's literal arguments (a ``${...}`` template is left to the tool)."""
    if tool in MAIL_TOOLS and (tool != "alerts.notify" or args.get("channel", "email") == "email"):
        literal = [a for a in _recipients(args.get("to")) if "${" not in a]
        refused = refused_recipients(config, literal)
        return [f"{a} is not on the alert allowlist ({RECIPIENT_SETTINGS})" for a in refused]
    url = args.get("url")
    if tool == "alerts.webhook" and isinstance(url, str) and "${" not in url:
        host = host_of(url)
        if host not in webhook_hosts(config):
            return [f"the webhook host {host or url[:40]!r} is not on the webhook allowlist ({HOST_SETTINGS})"]
    return []


__all__ = [
    "HOST_SETTINGS",
    "MAIL_TOOLS",
    "RECIPIENT_SETTINGS",
    "DestinationRefused",
    "allowed_recipients",
    "check_recipients_allowed",
    "check_webhook_allowed",
    "destination_problems",
    "host_of",
    "mail_leaves",
    "recipient_allowed",
    "refused_recipients",
    "webhook_hosts",
]
