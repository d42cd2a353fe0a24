"""Who answers at a ``--connect`` URL, and whether its link is signed as the run's ``--signing-key`` says: the probe
``swarm run --connect`` asks every vehicle with before anything flies, and ``run --connect`` asks its one vehicle
with (:func:`signing_problem`), so a key that does not match is said as such, not as a vehicle that never answered.

A vehicle that signs while the run has no key, signs with another key, or does not sign while the run has one would
refuse (or be refused by) every command: :class:`SigningMismatch`.

>>> parse_link("udp://127.0.0.1:14540")
('127.0.0.1', 14540)
"""

from __future__ import annotations

import contextlib
import select
import socket
import time
from typing import Any
from urllib.parse import urlsplit

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (
    MAV_AUTOPILOT_INVALID,
    MAV_CMD_GET_HOME_POSITION,
    MAV_COMP_ID_ONBOARD_COMPUTER,
    MAV_TYPE_GCS,
    MAV_TYPE_ONBOARD_CONTROLLER,
)

from flight.signing import Signer, Verdict

from ..contracts.errors import InputError, RunFailure

ASK_EVERY_S = 0.25
PROBE_SYSTEM = 254
"""The probe's own system id (not 255, the agent's client's: it is no ground station)."""
JUDGED_FRAMES = 3
"""Frames of the vehicle :func:`signing_problem` judges before it answers (one could be a stray)."""
SIGNING_PROBE_S = 3.0
"""How long :func:`signing_problem` listens for a vehicle before leaving the verdict to the connection itself."""


class VehicleUnreachable(RunFailure):
    """A ``--connect`` URL whose vehicle did not answer (exit status 1)."""


class SigningMismatch(RunFailure):
    """A ``--connect`` vehicle whose link is not signed as ``--signing-key`` says: it would refuse the run's
    commands, or its telemetry the run's client (exit status 1)."""


class Probe:
    """One URL asked who and where its vehicle is, over a socket of its own. It speaks as an onboard computer, not a
    ground station, so the vehicle never takes it for the commander whose silence is a lost data link."""

    def __init__(self, url: str, signing_key: bytes | None = None) -> None:
        self.url = url
        self.address = parse_link(url)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        self.mav = mavlink2.MAVLink(None, srcSystem=PROBE_SYSTEM, srcComponent=MAV_COMP_ID_ONBOARD_COMPUTER)
        self.plain = mavlink2.MAVLink(None, srcSystem=PROBE_SYSTEM, srcComponent=MAV_COMP_ID_ONBOARD_COMPUTER)
        self.signer = Signer(signing_key, required=True, allow_unsigned=frozenset()) if signing_key else None
        if self.signer is not None:
            self.signer.attach(self.mav)
        self.signed: set[str] = set()
        """How the vehicle's frames came: ``ours`` (with the key), ``other`` (another key), ``signed``, ``unsigned``."""
        self.system_id: int | None = None
        self.heard = 0
        """Frames heard from the vehicle (its system id's), judged or not."""
        self.home: tuple[float, float, float] | None = None

    def _signing_of(self, msg: Any) -> str:
        if self.signer is None:
            return "signed" if msg.get_header().incompat_flags & mavlink2.MAVLINK_IFLAG_SIGNED else "unsigned"
        verdict = self.signer.check(msg)
        return {Verdict.SIGNED: "ours", Verdict.REPLAYED: "ours", Verdict.BAD_SIGNATURE: "other"}.get(
            verdict, "unsigned"
        )

    def ask(self) -> None:
        beat = self.mav.heartbeat_encode(MAV_TYPE_ONBOARD_CONTROLLER, MAV_AUTOPILOT_INVALID, 0, 0, 0)
        # the heartbeat goes unsigned (taken unsigned by every vehicle, as PX4 does): a vehicle with another key
        # still learns the probe and streams to it, so the probe can say what is wrong rather than hear nothing
        frames = [bytes(beat.pack(self.plain))]
        if self.system_id is not None:
            if self.signer is not None:
                self.signer.tick()
            ask = self.mav.command_long_encode(self.system_id, 0, MAV_CMD_GET_HOME_POSITION, 0, *[0.0] * 7)
            frames.append(bytes(ask.pack(self.mav)))
        for frame in frames:
            with contextlib.suppress(OSError):  # nobody there (ICMP refused): the deadline says so
                self.sock.sendto(frame, self.address)

    def read(self) -> None:
        while True:
            try:
                data, _ = self.sock.recvfrom(65535)
            except OSError:
                return
            parser = mavlink2.MAVLink(None)  # no key: a frame signed with another key is parsed, then judged
            parser.robust_parsing = True
            for msg in parser.parse_buffer(data) or []:
                kind = msg.get_type()
                if kind == "HEARTBEAT" and msg.type != MAV_TYPE_GCS and self.system_id is None:
                    self.system_id = msg.get_srcSystem()
                if kind == "BAD_DATA" or msg.get_srcSystem() != self.system_id:
                    continue
                self.heard += 1
                signed = self._signing_of(msg)
                self.signed.add(signed)
                trusted = self.signer is None or signed == "ours"
                if kind == "HOME_POSITION" and trusted:
                    self.home = (msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)

    def mismatch(self) -> str | None:
        """Why the run's client and this vehicle could not talk, signing-wise (None: they can)."""
        who = f"--connect {self.url}: the vehicle (system id {self.system_id})"
        if self.signer is None:
            if "signed" in self.signed and "unsigned" not in self.signed:
                return f"{who} signs its link and refuses unsigned commands: give its key with --signing-key FILE"
            return None
        if "ours" in self.signed:
            return None
        if "other" in self.signed:
            return f"{who} signs with another key than --signing-key's: it would refuse every command"
        return f"{who} does not sign its link (it has no key): give it the key, or fly without --signing-key"

    @property
    def answered(self) -> bool:
        return self.system_id is not None and self.home is not None


def signing_problem(url: str, signing_key: bytes | None, timeout_s: float = SIGNING_PROBE_S) -> str | None:
    """Why the vehicle at ``url`` and a client signing with ``signing_key`` (None: not signing) could not talk, once
    :data:`JUDGED_FRAMES` of its frames are heard; None when they can, or when nothing answers within ``timeout_s``
    (the connection then says the vehicle is unreachable)."""
    probe = Probe(url, signing_key)
    try:
        deadline = time.monotonic() + timeout_s
        next_ask = 0.0
        while (now := time.monotonic()) < deadline and not (probe.system_id and probe.heard >= JUDGED_FRAMES):
            if now >= next_ask:
                probe.ask()
                next_ask = now + ASK_EVERY_S
            readable, _, _ = select.select([probe.sock], [], [], min(ASK_EVERY_S, max(0.0, deadline - now)))
            if readable:
                probe.read()
        return probe.mismatch() if probe.system_id is not None else None
    finally:
        probe.sock.close()


def parse_link(url: str) -> tuple[str, int]:
    """``udp://HOST:PORT`` (or ``HOST:PORT``) as an address; :class:`InputError` for anything else.

    >>> parse_link("udp://127.0.0.1:14540")
    ('127.0.0.1', 14540)
    """
    parts = urlsplit(url if "://" in url else f"udp://{url}")
    if parts.scheme not in ("udp", "udpout") or not parts.hostname or parts.port is None:
        raise InputError(f"--connect {url!r}: expected udp://HOST:PORT")
    return parts.hostname, parts.port


__all__ = [
    "ASK_EVERY_S",
    "PROBE_SYSTEM",
    "Probe",
    "SigningMismatch",
    "VehicleUnreachable",
    "parse_link",
    "signing_problem",
]
