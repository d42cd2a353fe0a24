"""The client's UDP link to one vehicle: the socket, the reader thread, our HEARTBEAT, and who the vehicle is.

Why: everything else in the client is asynchronous logic over messages; this is the one place that touches the
socket. :class:`Link` owns it on a *reader thread* that parses each datagram with pymavlink (a fresh robust parser
per datagram, so garbage cannot spoil the next one), keeps only messages from the vehicle, hands them in batches to
``on_messages`` under the client's lock, and sends our own HEARTBEAT once a second (ground stations do; PX4 counts
them for its data-link failsafe).

Addresses (as pymavlink's ``mavutil``): ``"HOST:PORT"``, ``"udpout:HOST:PORT"`` or ``(host, port)`` send to the
vehicle from an ephemeral port (the vehicle answers whoever talks to it; :class:`~flight.mavlink.MavlinkVehicle`
and PX4 do); ``"udpin:HOST:PORT"`` listens there (PX4 SITL sends to 127.0.0.1:14540 for APIs) and replies to where
the vehicle's messages come from.

The vehicle is the first system whose HEARTBEAT is not a ground station's (MAV_TYPE_GCS 6) nor
MAV_AUTOPILOT_INVALID 8, unless a system id was given.

Trust: only messages from the vehicle's address (the one sent to, resolved; when listening, the one its first
heartbeat came from) and system id are taken; anything else is counted in ``rx_foreign`` and ignored, so a
spoofer on another socket cannot feed the client telemetry. With a signing key (:mod:`flight.signing`) every
message we send is signed, and every message from the vehicle must be signed with the key and fresh (counted in
``signing.counters`` when not).
"""

from __future__ import annotations

import contextlib
import select
import socket
import threading
import time
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_AUTOPILOT_INVALID,
    MAV_TYPE_GCS,
)

from agentic_core.contracts.errors import RunFailure
from flight.signing import Signer

Address = tuple[str, int]
MAX_DATAGRAMS_PER_WAKE = 1000


def parse_address(address: str | Address) -> tuple[Address, bool]:
    """``(host, port)`` and whether to listen there (``udpin:``) rather than send to it."""
    if isinstance(address, tuple):
        return (str(address[0]), int(address[1])), False
    text = address.strip()
    listen = False
    for prefix, is_in in (("udpin:", True), ("udpout:", False), ("udp:", False)):
        if text.startswith(prefix):
            text, listen = text[len(prefix) :], is_in
            break
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"bad MAVLink address {address!r}: use HOST:PORT, udpin:HOST:PORT or udpout:HOST:PORT")
    return (host or "0.0.0.0", int(port)), listen


def _resolved(where: Address) -> Address:
    """``where`` with its host as the IPv4 address replies come from (a name resolved; any-address as loopback)."""
    host, port = where
    if host in ("", "0.0.0.0"):
        return "127.0.0.1", port
    try:
        return socket.gethostbyname(host), port
    except OSError as exc:
        raise VehicleConnectionError(f"cannot resolve the vehicle's host {host!r}: {exc}") from exc


class VehicleConnectionError(RunFailure, ConnectionError):
    """No heartbeat from a vehicle within the connect timeout (or the socket could not be opened)."""


class Link:
    """One UDP socket to one vehicle, read by a daemon thread once :meth:`start` ed. ``on_messages`` runs on that
    thread, under ``lock``."""

    def __init__(
        self,
        address: str | Address,
        *,
        mav: mavlink2.MAVLink,
        lock: threading.RLock,
        on_messages: Callable[[list[Any]], None],
        target_system: int | None = None,
        heartbeat_period_s: float = 1.0,
        signing_key: bytes | None = None,
    ) -> None:
        where, listen = parse_address(address)
        self.target_system = target_system
        """The vehicle's system id (learnt from its first heartbeat when not given)."""
        self.target_component = 1
        self.rx_messages = 0
        self.rx_dropped = 0
        self.on_wire: list[Callable[[bytes], None]] = []
        """Called with every frame sent to or kept from the vehicle (e.g. a flight log), in the sending or reading
        thread; what one raises is ignored."""
        self.rx_foreign = 0
        """Messages from another address than the vehicle's (or, once known, claiming its id from elsewhere)."""
        self.signing: Signer | None = None
        """With a key: signs what we send, and judges what we hear (nothing unsigned is taken from the vehicle)."""
        if signing_key is not None:
            self.signing = Signer(signing_key, required=True, allow_unsigned=frozenset(), link_id=1)
            self.signing.attach(mav)
        self._mav = mav
        self._lock = lock
        self._on_messages = on_messages
        self._heartbeat_period_s = heartbeat_period_s
        self._closed = threading.Event()
        remote = None if listen else _resolved(where)
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            loopback = where[0] in ("127.0.0.1", "localhost")
            self._sock.bind(where if listen else ("127.0.0.1" if loopback else "", 0))
            self._sock.setblocking(False)
        except OSError as exc:
            self._sock.close()
            raise VehicleConnectionError(f"cannot open a UDP socket for {address!r}: {exc}") from exc
        self.remote: Address | None = remote
        """Where the vehicle is (None until heard from, when listening)."""
        self._thread = threading.Thread(target=self._read_loop, name="mavlink-client", daemon=True)

    def start(self) -> None:
        """Start the reader thread (once whoever receives ``on_messages`` is ready for them)."""
        self._thread.start()

    @property
    def address(self) -> Address:
        """Our bound (host, port)."""
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    def close(self) -> None:
        """Stop the reader thread and close the socket (idempotent)."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._sock.close()

    def send(self, msg: Any) -> None:
        """Pack and send ``msg`` to the vehicle (dropped while its address is unknown or after close)."""
        remote = self.remote
        if remote is None or self._closed.is_set():
            return
        with self._lock:
            if self.signing is not None:
                self.signing.tick()
            buf = msg.pack(self._mav)
            self._mav.seq = (self._mav.seq + 1) % 256
        try:
            self._sock.sendto(buf, remote)
        except OSError:
            return
        self._tap(buf)

    def _tap(self, frame: bytes) -> None:
        for hook in self.on_wire:
            with contextlib.suppress(Exception):
                hook(frame)

    # -- the reader thread ------------------------------------------------------------------------------------

    def _read_loop(self) -> None:
        next_beat = 0.0
        while not self._closed.is_set():
            now = time.monotonic()
            if now >= next_beat:
                next_beat = now + self._heartbeat_period_s
                self.send(self._mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0))
            try:
                readable, _, _ = select.select([self._sock], [], [], min(0.1, max(0.0, next_beat - now)))
            except (OSError, ValueError):  # closed under us
                return
            if not readable:
                continue
            for _ in range(MAX_DATAGRAMS_PER_WAKE):
                try:
                    data, sender = self._sock.recvfrom(65535)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    if self._closed.is_set():
                        return
                    break
                self._datagram(data, (str(sender[0]), int(sender[1])))

    def _datagram(self, data: bytes, sender: Address) -> None:
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True
        try:
            msgs = [m for m in parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]
        except Exception:
            msgs = []
        if not msgs:
            self.rx_dropped += 1
            return
        with self._lock:
            if self.remote is not None and sender != self.remote:
                self.rx_foreign += len(msgs)
                return
            signing = self.signing
            if signing is not None:
                msgs = [msg for msg in msgs if signing.check(msg).accepted]
            mine = [msg for msg in msgs if self._from_vehicle(msg, sender)]
            self.rx_messages += len(mine)
            for msg in mine:
                self._tap(msg.get_msgbuf())
            if mine:
                self._on_messages(mine)

    def _from_vehicle(self, msg: Any, sender: Address) -> bool:
        src = msg.get_srcSystem()
        if self.target_system is None:
            if msg.get_type() != "HEARTBEAT" or msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
                return False
            self.target_system, self.target_component = src, msg.get_srcComponent()
        if src != self.target_system:
            return False
        if self.remote is None:
            self.remote = sender
        return True
