"""Who may use the console: the address it binds, the token every API request carries, and the Origin every
state-changing request must come from. Pure functions, no web framework, so the rules are tested on their own.

On 127.0.0.1 a token is made for each server when none is given; anywhere else a person must give one
(``--token`` or ``$AGENTIC_UAV_CONSOLE_TOKEN``), because the page and its controls are then reachable by others.

>>> check_bind("127.0.0.1", None)
>>> try:
...     check_bind("0.0.0.0", None)
... except InputError as exc:
...     print(exc)
console: binding 0.0.0.0 (not a loopback address) needs a token: --token or $AGENTIC_UAV_CONSOLE_TOKEN
>>> guard = Guard("s3cret-token-123")
>>> guard.refuse_change({"authorization": "Bearer s3cret-token-123", "origin": "http://127.0.0.1:8765",
...                      "host": "127.0.0.1:8765"})
>>> guard.refuse_change({"authorization": "Bearer s3cret-token-123", "origin": "http://evil.example",
...                      "host": "127.0.0.1:8765"})
'the request comes from http://evil.example, not from this console (http://127.0.0.1:8765)'
"""

from __future__ import annotations

import hmac
import ipaddress
import secrets
from collections.abc import Mapping

from ..contracts.errors import InputError

TOKEN_ENV = "AGENTIC_UAV_CONSOLE_TOKEN"
MIN_TOKEN_CHARS = 12
"""A token a person chooses must be at least this long: a short one is guessed."""


def is_loopback(host: str) -> bool:
    """True for 127.0.0.0/8, ::1 and ``localhost``: addresses only this machine reaches."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def check_bind(host: str, token: str | None) -> None:
    """:class:`InputError` when the console would listen beyond this machine without a token, or with a short one."""
    if token is not None and len(token) < MIN_TOKEN_CHARS:
        raise InputError(f"console: the token is too short ({len(token)} characters; at least {MIN_TOKEN_CHARS})")
    if token is None and not is_loopback(host):
        raise InputError(f"console: binding {host} (not a loopback address) needs a token: --token or ${TOKEN_ENV}")


def make_token() -> str:
    """A fresh random token (for a console on 127.0.0.1 started without one)."""
    return secrets.token_urlsafe(24)


class Guard:
    """Checks one request's token (``Authorization: Bearer``, or ``?token=`` where a browser cannot set headers:
    an EventSource) and, for a change, its Origin. Each check returns None, or why the request is refused."""

    def __init__(self, token: str, *, loopback_only: bool = False) -> None:
        self.token = token
        self.loopback_only = loopback_only

    def refuse_read(self, headers: Mapping[str, str], query: Mapping[str, str]) -> str | None:
        """Why a read of the API is refused (no token, a wrong one), or None."""
        given = _bearer(headers) or query.get("token")
        return None if given is not None and self._matches(given) else "no valid token"

    def refuse_change(self, headers: Mapping[str, str]) -> str | None:
        """Why a state-changing request is refused: it needs the token in its Authorization header (never in the
        URL, which lands in logs) and an Origin equal to the console's own (a page elsewhere cannot drive it)."""
        given = _bearer(headers)
        if given is None or not self._matches(given):
            return "no valid token"
        origin = headers.get("origin")
        own = f"http://{headers.get('host', '')}"
        if origin is None:
            return "the request has no Origin"
        if self.loopback_only and not is_loopback(_hostname(headers.get("host", ""))):
            return f"the request names host {headers.get('host')!r}, not this machine"
        if origin != own:
            return f"the request comes from {origin}, not from this console ({own})"
        return None

    def _matches(self, given: str) -> bool:
        return hmac.compare_digest(given.encode("utf-8"), self.token.encode("utf-8"))


def _hostname(host: str) -> str:
    """``127.0.0.1:8765`` -> ``127.0.0.1``; ``[::1]:8765`` -> ``::1``."""
    if host.startswith("["):
        return host[1:].partition("]")[0]
    return host.rpartition(":")[0] if host.count(":") == 1 else host


def _bearer(headers: Mapping[str, str]) -> str | None:
    value = headers.get("authorization", "")
    scheme, _, token = value.partition(" ")
    return token.strip() if scheme.lower() == "bearer" and token.strip() else None


__all__ = ["MIN_TOKEN_CHARS", "TOKEN_ENV", "Guard", "check_bind", "is_loopback", "make_token"]
