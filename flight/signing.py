"""MAVLink 2 message signing for both ends of a link: keys, key files, and whether a received frame is to be trusted.

Why: without signing, anyone who can send the vehicle a UDP datagram commands it, and anyone who can send the
agent's client one feeds it telemetry. :class:`Signer` wraps pymavlink's own signing state
(``MAVLink.signing``, a :class:`~pymavlink.dialects.v20.common.MAVLinkSigning`) so that the encoder signs what it
sends and every received frame is judged by :meth:`Signer.check` with counters of what was refused.

Facts relied on (mavlink.io "Message signing"; pymavlink's ``MAVLink_message.sign_packet`` and
``MAVLink.check_signature``; PX4's "MAVLink Message Signing" page):

* A signed frame has incompat flag 0x01 and a 13-byte trailer: link id (1 byte), timestamp (6 bytes, units of
  10 µs since 2015-01-01 00:00 GMT), signature (6 bytes): the first 48 bits of SHA-256 over the secret key, the
  header, payload and CRC, the link id and the timestamp.
* Replay: a *stream* is (link id, system id, component id); a frame whose timestamp is not newer than the last
  accepted on its stream is refused; a new stream is refused when its timestamp is more than a minute behind ours.
  pymavlink keeps these timestamps in ``signing.stream_timestamps`` and raises its own timestamp to the newest it
  accepted; it records a stream's timestamp *before* comparing signatures, so :meth:`Signer.check` applies the same
  rules itself after the signature, hashing each frame once: a forged frame with a future timestamp cannot lock a
  stream's real sender out.
* PX4 accepts HEARTBEAT 0, RADIO_STATUS 109, ADSB_VEHICLE 246 and COLLISION 247 unsigned while signing is on
  (:data:`UNSIGNED_ALLOWED`); PX4 stores the key as 32 bytes of key then the timestamp as a little-endian uint64
  (``mavlink-signing-key.bin``, mode 0600, its directory 0700).

>>> key = bytes(range(32))
>>> parse_key(key.hex(), source="k") == key, parse_key(key, source="k") == key
(True, True)
"""

from __future__ import annotations

import hashlib
import os
import secrets
import stat
import struct
import time
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2

from agentic_core.contracts.errors import InputError

KEY_LEN = 32
EPOCH_2015_S = 1420070400
"""2015-01-01 00:00:00 GMT as a Unix time: the signing timestamp's origin."""
MAX_KEY_FILE_BYTES = 4096
UNSIGNED_ALLOWED = frozenset({0, 109, 246, 247})
"""Messages PX4 accepts unsigned while signing is on: HEARTBEAT, RADIO_STATUS, ADSB_VEHICLE, COLLISION."""
MSG_SETUP_SIGNING = mavlink2.MAVLINK_MSG_ID_SETUP_SIGNING
_SIGNED_FLAG = mavlink2.MAVLINK_IFLAG_SIGNED
_STORE = struct.Struct("<32sQ")
_NEW_STREAM_SLACK = 6000 * 1000  # a minute, in the timestamp's 10 µs units


def now_timestamp() -> int:
    """The signing timestamp of now: 10 µs units since 2015-01-01 GMT."""
    return int((time.time() - EPOCH_2015_S) * 100_000)


def new_key() -> bytes:
    """A fresh random 32-byte secret key."""
    return secrets.token_bytes(KEY_LEN)


def parse_key(data: bytes | str, *, source: str) -> bytes:
    """A 32-byte key from its raw bytes or 64 hexadecimal digits (surrounding whitespace ignored); InputError
    naming ``source`` otherwise (never the key itself)."""
    raw = data.encode("ascii", "replace") if isinstance(data, str) else bytes(data)
    if len(raw) == KEY_LEN:
        return raw
    text = raw.strip()
    if len(text) == 2 * KEY_LEN:
        try:
            return bytes.fromhex(text.decode("ascii"))
        except (UnicodeDecodeError, ValueError):
            pass
    raise InputError(
        f"{source}: not a signing key: expected 32 raw bytes or 64 hexadecimal digits, got {len(raw)} bytes"
    )


def read_key_file(path: str | Path) -> bytes:
    """The key in ``path`` (32 raw bytes or 64 hex digits); InputError naming the file when it is not one."""
    p = Path(path)
    try:
        info = p.stat()
        if not stat.S_ISREG(info.st_mode):
            raise InputError(f"{p}: not a regular file")
        if info.st_size > MAX_KEY_FILE_BYTES:
            raise InputError(f"{p}: not a signing key: {info.st_size} bytes is too long")
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{p}: cannot read the signing key: {exc.strerror or exc}") from None
    return parse_key(data, source=str(p))


def _write_private(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` readable by its owner only (0600; a new directory 0700), replacing it atomically."""
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.fchmod(fd, 0o600)
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(tmp, path)


def write_key_file(path: str | Path, key: bytes) -> None:
    """Write ``key`` as hexadecimal to ``path``, mode 0600 (what :func:`read_key_file` and ``--signing-key`` read)."""
    _write_private(Path(path), key.hex().encode("ascii") + b"\n")


class KeyStore:
    """A vehicle's persistent key, stored as PX4 stores it: 32 bytes of key, then the timestamp (uint64 LE)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)

    def load(self) -> tuple[bytes, int] | None:
        """(key, timestamp), or None when there is no file or it holds the all-zero "no key"; InputError when the
        file is not a key store."""
        try:
            data = self.path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise InputError(f"{self.path}: cannot read the signing key store: {exc.strerror or exc}") from None
        if len(data) != _STORE.size:
            raise InputError(f"{self.path}: not a signing key store: {len(data)} bytes, expected {_STORE.size}")
        key, timestamp = _STORE.unpack(data)
        return None if key == bytes(KEY_LEN) and timestamp == 0 else (key, timestamp)

    def save(self, key: bytes | None, timestamp: int) -> None:
        """Store ``key`` (None: remove the file, signing off)."""
        if key is None:
            self.path.unlink(missing_ok=True)
            return
        _write_private(self.path, _STORE.pack(key, timestamp))


class Verdict(Enum):
    """What :meth:`Signer.check` made of a frame."""

    SIGNED = "signed"
    """Signed with the key, fresh: authenticated."""
    OPEN = "open"
    """Signing is off: accepted, not authenticated."""
    ALLOWED_UNSIGNED = "allowed unsigned"
    """Unsigned but one of the messages accepted so: accepted, not authenticated."""
    UNSIGNED = "unsigned"
    BAD_SIGNATURE = "bad signature"
    REPLAYED = "replayed"
    NO_KEY = "no key"
    """Signing is required and there is no key yet: refused."""

    @property
    def accepted(self) -> bool:
        return self in (Verdict.SIGNED, Verdict.OPEN, Verdict.ALLOWED_UNSIGNED)


@dataclass(slots=True)
class SigningCounters:
    """What :meth:`Signer.check` accepted and refused, by reason."""

    signed: int = 0
    allowed_unsigned: int = 0
    unsigned: int = 0
    bad_signature: int = 0
    replayed: int = 0
    no_key: int = 0

    @property
    def refused(self) -> int:
        return self.unsigned + self.bad_signature + self.replayed + self.no_key

    def count(self, verdict: Verdict) -> None:
        if verdict is Verdict.OPEN:
            return
        name = verdict.name.lower()
        setattr(self, name, getattr(self, name) + 1)

    def as_dict(self) -> dict[str, int]:
        return {
            "signed": self.signed,
            "allowed_unsigned": self.allowed_unsigned,
            "unsigned": self.unsigned,
            "bad_signature": self.bad_signature,
            "replayed": self.replayed,
            "no_key": self.no_key,
        }


class Signer:
    """One end's signing: the key, its outgoing timestamp, the replay window of every stream it hears, counters.

    ``required``: with no key, refuse everything but :data:`UNSIGNED_ALLOWED` (rather than accept all).
    ``allow_unsigned``: the messages accepted unsigned while a key is set. :meth:`attach` makes an encoder sign."""

    def __init__(
        self,
        key: bytes | None = None,
        *,
        required: bool = False,
        link_id: int = 0,
        allow_unsigned: frozenset[int] = UNSIGNED_ALLOWED,
        timestamp: int = 0,
    ) -> None:
        if not 0 <= link_id <= 255:
            raise ValueError("link_id is 0..255")
        self.state = mavlink2.MAVLinkSigning()
        self.state.link_id = link_id
        self.required = required
        self.allow_unsigned = allow_unsigned
        self.counters = SigningCounters()
        self.set_key(key, timestamp)

    @property
    def key(self) -> bytes | None:
        key = self.state.secret_key
        return None if key is None else bytes(key)

    @property
    def active(self) -> bool:
        """Whether a key is set (outgoing frames are signed, incoming ones must be)."""
        return self.state.secret_key is not None

    def attach(self, mav: mavlink2.MAVLink) -> None:
        """Make ``mav`` sign with this state (its frames then carry this end's timestamps)."""
        mav.signing = self.state

    def set_key(self, key: bytes | None, timestamp: int = 0) -> None:
        """Use ``key`` from now on (None: signing off); streams heard under another key start afresh."""
        if key is not None and len(key) != KEY_LEN:
            raise ValueError("a signing key is 32 bytes")
        self.state.secret_key = None if key is None else bytes(key)
        self.state.sign_outgoing = key is not None
        self.state.stream_timestamps = {}
        self.state.timestamp = max(self.state.timestamp, timestamp, now_timestamp())

    def tick(self) -> None:
        """Keep the outgoing timestamp at least the time now (a peer refuses a new stream a minute behind its own)."""
        if self.state.sign_outgoing:
            now = now_timestamp()
            if now > self.state.timestamp:
                self.state.timestamp = now

    def check(self, msg: Any, *, provisioning: bool = False) -> Verdict:
        """Judge one parsed frame (and count it). ``provisioning``: with no key, a SETUP_SIGNING may be taken."""
        verdict = self._judge(msg, provisioning)
        self.counters.count(verdict)
        return verdict

    def _judge(self, msg: Any, provisioning: bool) -> Verdict:
        key = self.state.secret_key
        msg_id = msg.get_msgId()
        if key is None:
            if not self.required or (provisioning and msg_id == MSG_SETUP_SIGNING):
                return Verdict.OPEN
            return Verdict.ALLOWED_UNSIGNED if msg_id in self.allow_unsigned else Verdict.NO_KEY
        if not msg.get_header().incompat_flags & _SIGNED_FLAG:
            return Verdict.ALLOWED_UNSIGNED if msg_id in self.allow_unsigned else Verdict.UNSIGNED
        buf = msg.get_msgbuf()
        if len(buf) < 13:
            return Verdict.BAD_SIGNATURE
        digest = hashlib.sha256(key)
        digest.update(memoryview(buf)[:-6])
        if digest.digest()[:6] != bytes(buf[-6:]):
            return Verdict.BAD_SIGNATURE
        return Verdict.SIGNED if self._fresh(buf, msg.get_srcSystem(), msg.get_srcComponent()) else Verdict.REPLAYED

    def _fresh(self, buf: bytes | bytearray, system: int, component: int) -> bool:
        """The replay rule of MAVLink 2 signing, for a frame whose signature is good: a stream's timestamps only go
        up, and a new stream may start at most a minute behind this end's clock. Checked after the signature, so a
        forged frame cannot move a stream's clock (pymavlink's own check moves it first)."""
        timestamp = int.from_bytes(buf[-12:-6], "little")
        stream = (buf[-13], system, component)
        state = self.state
        last = state.stream_timestamps.get(stream)
        if (timestamp <= last) if last is not None else (timestamp + _NEW_STREAM_SLACK < state.timestamp):
            return False
        state.stream_timestamps[stream] = timestamp
        state.timestamp = max(state.timestamp, timestamp)
        return True


__all__ = [
    "KEY_LEN",
    "UNSIGNED_ALLOWED",
    "KeyStore",
    "Signer",
    "SigningCounters",
    "Verdict",
    "new_key",
    "now_timestamp",
    "parse_key",
    "read_key_file",
    "write_key_file",
]
