"""Messages a UAV can trust: every swarm message is signed with the swarm's key (HMAC-SHA256) and checked on
arrival — its signature first, then its age, then its nonce — and refused when forged, stale or replayed; every
refusal goes to the audit. A2A signs Agent Cards, not messages, and has no replay protection: this adds both.

One key per swarm authenticates membership, not the member: any holder of the key can sign as any sender.

>>> key = SwarmKey.generate("mina")
>>> seal = Sealer(key, "ground", clock=lambda: 100.0)
>>> guard = Guard(key, "uav-1", clock=lambda: 101.0)
>>> message = seal.seal("cfp", {"task": "T-1"})
>>> guard.check(message).body
{'task': 'T-1'}
>>> try:
...     guard.check(message)
... except Refused as exc:
...     print(exc.rejection.reason)
replayed
"""

from __future__ import annotations

import hashlib
import heapq
import hmac
import json
import secrets
import threading
import time
from collections.abc import Callable, Collection, Mapping
from pathlib import Path
from typing import Any, Protocol

from pydantic import ValidationError

from agentic_core.contracts.errors import AgenticUAVError, InputError
from agentic_core.contracts.swarm import MessageKind, Rejection, SwarmMessage

Clock = Callable[[], float]

MIN_KEY_BYTES = 32
MAX_AGE_S = 30.0
"""How old (or how far in the future) a message may be: the replay window, and so how long nonces are kept."""
MAX_NONCES = 100_000
"""Nonces kept at most; past it the oldest go first, and a message no newer than one forgotten is refused stale."""


class SwarmKey:
    """A swarm's shared secret (at least 32 bytes) and the swarm's name; ``repr`` never shows the secret."""

    def __init__(self, swarm: str, secret: bytes) -> None:
        if len(secret) < MIN_KEY_BYTES:
            raise InputError(f"swarm {swarm!r}: the key has {len(secret)} bytes, at least {MIN_KEY_BYTES} needed")
        self.swarm = swarm
        self._secret = secret

    @classmethod
    def generate(cls, swarm: str) -> SwarmKey:
        """A fresh random key."""
        return cls(swarm, secrets.token_bytes(MIN_KEY_BYTES))

    @classmethod
    def from_file(cls, swarm: str, path: Path) -> SwarmKey:
        """The key in ``path`` (hex text); a missing, unreadable or short file is an :class:`InputError`."""
        try:
            return cls(swarm, bytes.fromhex(path.read_text(encoding="ascii").strip()))
        except (OSError, ValueError) as exc:
            raise InputError(f"{path}: not a swarm key ({exc})") from exc

    def sign(self, text: str) -> str:
        """The hex HMAC-SHA256 of ``text`` under this key, the swarm's name bound in."""
        mac = hmac.new(self._secret, f"{self.swarm}\n".encode(), hashlib.sha256)
        mac.update(text.encode("utf-8"))
        return mac.hexdigest()

    def __repr__(self) -> str:
        return f"SwarmKey({self.swarm!r}, <secret>)"


class Sealer:
    """Signs what one member sends: a fresh nonce and the member's clock on every message."""

    def __init__(self, key: SwarmKey, sender: str, *, clock: Clock = time.time) -> None:
        self.key = key
        self.sender = sender
        self._clock = clock

    def seal(
        self, kind: MessageKind, body: Mapping[str, Any], *, recipient: str | None = None, conversation: str = ""
    ) -> SwarmMessage:
        """A signed message of ``kind`` with ``body``."""
        unsigned = SwarmMessage(
            kind=kind,
            sender=self.sender,
            recipient=recipient,
            conversation=conversation,
            nonce=secrets.token_hex(16),
            timestamp=self._clock(),
            body=dict(body),
        )
        return unsigned.model_copy(update={"signature": self.key.sign(unsigned.signed_text())})


class Audit(Protocol):
    """Where refusals go."""

    def record(self, rejection: Rejection) -> None:
        """Keep one refusal."""


class MemoryAudit:
    """Refusals kept in a list (tests, and a run that writes them out at its end)."""

    def __init__(self) -> None:
        self.rejections: list[Rejection] = []
        self._lock = threading.Lock()

    def record(self, rejection: Rejection) -> None:
        """Append one refusal."""
        with self._lock:
            self.rejections.append(rejection)

    def reasons(self) -> list[str]:
        """The reasons, in order."""
        with self._lock:
            return [r.reason for r in self.rejections]


class JsonlAudit:
    """Refusals appended to a JSON Lines file, one line each, flushed at once."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._lock = threading.Lock()

    def record(self, rejection: Rejection) -> None:
        """Append one refusal as a line."""
        with self._lock, self.path.open("a", encoding="utf-8") as out:
            out.write(rejection.model_dump_json() + "\n")


class Refused(AgenticUAVError):
    """A swarm message refused on arrival; ``rejection`` says why (and has been audited)."""

    def __init__(self, rejection: Rejection) -> None:
        super().__init__(f"refused {rejection.kind or 'message'} from {rejection.sender!r}: {rejection.reason}")
        self.rejection = rejection


class Guard:
    """Checks what one member receives: signature, age, nonce, sender and recipient; audits every refusal.

    Thread-safe: a UAV's A2A server checks messages from its own loop while the agent checks its replies."""

    def __init__(
        self,
        key: SwarmKey,
        receiver: str,
        *,
        audit: Audit | None = None,
        clock: Clock = time.time,
        max_age_s: float = MAX_AGE_S,
        members: Collection[str] | None = None,
        max_nonces: int = MAX_NONCES,
    ) -> None:
        self.key = key
        self.receiver = receiver
        self.audit = audit or MemoryAudit()
        self.members = None if members is None else frozenset(members)
        self._clock = clock
        self._max_age_s = max_age_s
        self._max_nonces = max_nonces
        self._seen: set[tuple[str, str]] = set()
        self._expiry: list[tuple[float, str, str]] = []
        self._floor = float("-inf")
        self._lock = threading.Lock()

    def parse(self, raw: str | bytes | Mapping[str, Any]) -> SwarmMessage:
        """Check a message as it came off the wire (JSON text or parsed JSON): malformed input is refused too."""
        data: object = None
        try:
            data = json.loads(raw) if isinstance(raw, str | bytes) else dict(raw)
            message = SwarmMessage.model_validate(data)
        except (ValueError, TypeError, ValidationError) as exc:
            claimed = data.get("sender", "") if isinstance(data, dict) else ""
            detail = " ".join(str(exc).split())[:200]
            raise self.refuse("malformed", detail, sender=str(claimed)[:64]) from None
        return self.check(message)

    def check(self, message: SwarmMessage) -> SwarmMessage:
        """``message`` if it is genuine, fresh, new and for this member; else :class:`Refused`, audited."""
        expected = self.key.sign(message.signed_text())
        if not hmac.compare_digest(expected, message.signature):
            raise self.refuse("forged", "the signature does not match", message)
        if self.members is not None and message.sender not in self.members:
            raise self.refuse("unknown_sender", "not a member of the swarm", message)
        if message.recipient is not None and message.recipient != self.receiver:
            raise self.refuse("misaddressed", f"addressed to {message.recipient!r}", message)
        now = self._clock()
        age = now - message.timestamp
        if abs(age) > self._max_age_s:
            raise self.refuse("stale", f"{age:+.1f} s old, {self._max_age_s:g} s allowed", message)
        with self._lock:
            self._forget(now)
            if message.timestamp <= self._floor:
                raise self.refuse("stale", "no newer than a nonce already forgotten", message)
            key = (message.sender, message.nonce)
            if key in self._seen:
                raise self.refuse("replayed", "nonce already used", message)
            self._seen.add(key)
            heapq.heappush(self._expiry, (message.timestamp, *key))
            if len(self._seen) > self._max_nonces:
                oldest, sender, nonce = heapq.heappop(self._expiry)
                self._seen.discard((sender, nonce))
                self._floor = max(self._floor, oldest)
        return message

    def _forget(self, now: float) -> None:
        """Drop nonces older than the window: a message that old is refused stale anyway."""
        horizon = now - self._max_age_s
        while self._expiry and self._expiry[0][0] < horizon:
            _, sender, nonce = heapq.heappop(self._expiry)
            self._seen.discard((sender, nonce))

    def refuse(self, reason: Any, detail: str, message: SwarmMessage | None = None, *, sender: str = "") -> Refused:
        """Audit a refusal of ``message`` (or of garbage claimed to come from ``sender``) and return its error."""
        rejection = Rejection(
            at=self._clock(),
            receiver=self.receiver,
            reason=reason,
            detail=detail,
            sender=message.sender if message else sender,
            kind=message.kind if message else "",
            nonce=message.nonce if message else "",
        )
        self.audit.record(rejection)
        return Refused(rejection)


__all__ = ["MAX_AGE_S", "Audit", "Guard", "JsonlAudit", "MemoryAudit", "Refused", "Sealer", "SwarmKey"]
