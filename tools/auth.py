"""Who calls a tool and what they may do: callers with scopes, and signed, expiring scope tokens (JWT, HS256).

A tool lists the scopes it needs; a caller must hold all of them. Scopes look like ``flight:command``; a caller's
``flight:*`` holds every ``flight:`` scope and ``*`` holds all.
"""

from __future__ import annotations

import base64
import binascii
import json
import os
import time
import unicodedata
import uuid
from collections.abc import Callable, Iterable
from typing import Any

import jwt
from pydantic import BaseModel, ConfigDict

from agentic_core.contracts.errors import AgenticUAVError

MIN_SECRET_BYTES = 32
SECRET_ENV = "AGENTIC_UAV_TOKEN_SECRET"


class Caller(BaseModel):
    """An authenticated caller: an id for the audit log and the scopes it holds."""

    model_config = ConfigDict(frozen=True)

    id: str
    scopes: frozenset[str] = frozenset()

    def allows(self, scope: str) -> bool:
        if scope in self.scopes or "*" in self.scopes:
            return True
        namespace, sep, _ = scope.partition(":")
        return bool(sep) and f"{namespace}:*" in self.scopes

    def missing(self, scopes: Iterable[str]) -> list[str]:
        return [s for s in scopes if not self.allows(s)]


ANONYMOUS = Caller(id="anonymous")
MAX_CLAIMED_CHARS = 64
_MAX_TOKEN_CHARS = 8192


def claimed_subject(token: str) -> str:
    """The subject a token claims, read without verifying it (never trust it: it is for the audit log), printable
    and at most ``MAX_CLAIMED_CHARS`` characters; ``?`` when the token says none.

    >>> import jwt
    >>> claimed_subject(jwt.encode({"sub": "mallory\\n\\u202eadmin"}, "k" * 32)), claimed_subject("garbage")
    ('mallory admin', '?')
    """
    parts = token.strip().split(".") if len(token) <= _MAX_TOKEN_CHARS else []
    try:
        claims = json.loads(base64.urlsafe_b64decode(parts[1] + "=" * (-len(parts[1]) % 4))) if len(parts) == 3 else {}
    except (ValueError, binascii.Error, RecursionError):
        claims = {}
    subject = claims.get("sub") if isinstance(claims, dict) else None
    if not isinstance(subject, str):
        return "?"
    shown = "".join(c if unicodedata.category(c)[0] not in "CZ" else " " for c in subject)  # no controls, bidi
    shown = " ".join(shown.split())
    if len(shown) > MAX_CLAIMED_CHARS:
        shown = shown[: MAX_CLAIMED_CHARS - 1] + "…"
    return shown or "?"


def unverified_caller(token: str) -> Caller:
    """Who a refused token claims to be, with no scopes: ``unverified: <claimed subject>``, for the audit log."""
    return Caller(id=f"unverified: {claimed_subject(token)}")


class InvalidToken(AgenticUAVError):
    """A token that is malformed, forged, expired or for another issuer; the message says which."""


class TokenAuthority:
    """Issues and verifies scope tokens signed with a shared secret.

    >>> authority = TokenAuthority("x" * 32)
    >>> authority.verify(authority.issue("mission:patrol", ["flight:*"], ttl_s=60)).allows("flight:command")
    True
    """

    algorithm = "HS256"

    def __init__(
        self,
        secret: str | bytes,
        *,
        issuer: str = "agentic-uavs",
        clock: Callable[[], float] = time.time,
        leeway_s: float = 30.0,
    ) -> None:
        key = secret.encode() if isinstance(secret, str) else secret
        if len(key) < MIN_SECRET_BYTES:
            raise ValueError(f"the token secret must be at least {MIN_SECRET_BYTES} bytes (got {len(key)})")
        self._key = key
        self.issuer = issuer
        self.clock = clock
        self.leeway_s = leeway_s  # clock skew allowed between issuer and verifier for 'iat'/'nbf'

    @classmethod
    def from_env(cls, variable: str = SECRET_ENV) -> TokenAuthority | None:
        """The authority whose secret is in ``variable``, or None when it is unset."""
        secret = os.environ.get(variable)
        return cls(secret) if secret else None

    def issue(self, subject: str, scopes: Iterable[str], *, ttl_s: float = 3600.0) -> str:
        if ttl_s <= 0:
            raise ValueError("ttl_s must be positive")
        now = self.clock()
        claims: dict[str, Any] = {
            "sub": subject,
            "scope": " ".join(sorted(set(scopes))),
            "iss": self.issuer,
            "iat": int(now),
            "exp": now + ttl_s,
            "jti": uuid.uuid4().hex,
        }
        return jwt.encode(claims, self._key, algorithm=self.algorithm)

    def verify(self, token: str) -> Caller:
        """The caller a token names; :class:`InvalidToken` when it is not valid now."""
        try:
            claims = jwt.decode(
                token,
                self._key,
                algorithms=[self.algorithm],
                issuer=self.issuer,
                # times are checked below, on this authority's clock (PyJWT would use the wall clock)
                options={
                    "require": ["exp", "sub", "iss"],
                    "verify_exp": False,
                    "verify_iat": False,
                    "verify_nbf": False,
                },
            )
        except jwt.InvalidTokenError as exc:
            raise InvalidToken(f"invalid token: {exc}") from None
        now = self.clock()
        expires, not_before = claims["exp"], claims.get("nbf", claims.get("iat", 0))
        if not isinstance(expires, int | float) or not isinstance(not_before, int | float):
            raise InvalidToken("invalid token: 'exp', 'nbf' and 'iat' must be numbers")
        if expires <= now:
            raise InvalidToken("invalid token: it has expired")
        if not_before > now + self.leeway_s:
            raise InvalidToken("invalid token: it is not valid yet (issued in the future)")
        scope = claims.get("scope", "")
        if not isinstance(scope, str) or not isinstance(claims["sub"], str):
            raise InvalidToken("invalid token: 'sub' and 'scope' must be strings")
        return Caller(id=claims["sub"], scopes=frozenset(scope.split()))
