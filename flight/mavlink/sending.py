"""The vehicle's sending side: destinations, frames, STATUSTEXT, and the streams each link asked for.

Why: keeps :mod:`flight.mavlink.vehicle` to the link's lifecycle and dispatch. :class:`Sender` is a mixin of
:class:`~flight.mavlink.vehicle.MavlinkVehicle`. Streams go out on the vehicle's default
:class:`~flight.mavlink.links.StreamSchedule` to the configured targets and to every peer without rates of its own,
and on each other peer's own schedule to that peer alone (PX4 keeps one rate table per link); a frame due on
several schedules in the same tick is packed once.

STATUSTEXT carries 50 characters; longer texts go in chunks sharing a non-zero ``id`` with rising ``chunk_seq``, the
last one shorter than 50 (an empty one if the text is a multiple of 50 long).
"""

from __future__ import annotations

import math
import socket
from collections import deque
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import MAV_SEVERITY_WARNING  # MAVLink's own constant

from flight.mavlink.failures import FailureInjector
from flight.mavlink.links import LinkTable, StreamSchedule
from flight.mavlink.telemetry import Fields, LinkStats, WireCodec
from flight.sim import Simulator

Address = tuple[str, int]
STATUSTEXT_LEN = 50


class Sender:
    """Sending, mixed into the vehicle, which provides the attributes below."""

    sim: Simulator
    stats: LinkStats
    failures: FailureInjector
    links: LinkTable
    streams: StreamSchedule
    statustexts: deque[tuple[int, str]]
    _mav: mavlink2.MAVLink
    _sock: socket.socket
    _targets: list[Address]
    _builders: dict[int, tuple[WireCodec, Callable[[], Fields]]]
    _text_id: int
    _lock: Any
    _in_hand: Address | None
    """The address of the message being handled (None: a call from this process)."""
    _destinations_cache: tuple[int, tuple[Address, ...]] | None
    on_wire: list[Callable[[bytes], None]]
    """Called with every frame sent (and every valid one taken in), e.g. a flight log's writer."""
    _hook_failed: Callable[[object, Exception], None]

    def _destinations(self) -> tuple[Address, ...]:
        """The configured targets, then every peer not among them, that take the default streams (cached)."""
        cached = self._destinations_cache
        links = self.links
        if cached is not None and cached[0] == links.version:
            return cached[1]
        peers = links.peers
        out = [a for a in self._targets if a not in peers or peers[a].schedule is None]
        out.extend(a for a, p in peers.items() if a not in self._targets and p.schedule is None)
        everyone = tuple(out)
        self._destinations_cache = (links.version, everyone)
        return everyone

    def _everyone(self) -> list[Address]:
        """Every target and peer (for messages that are not streams)."""
        out = list(self._targets)
        out.extend(a for a in self.links.peers if a not in out)
        return out

    def _send(self, msg: Any, to: Address | None = None, *, force: bool = False) -> None:
        """Send ``msg`` to ``to``, or to every target and peer (nothing while an injected failure has the link off,
        unless ``force``)."""
        self._transmit(msg.pack(self._mav), self._everyone() if to is None else (to,), force=force)

    def _transmit(
        self, buf: bytes, to: tuple[Address, ...] | list[Address], *, force: bool = False, tap: bool = True
    ) -> None:
        """Send a frame packed with the current sequence number to ``to``, and count it as sent (and, with ``tap``,
        hand it to the ``on_wire`` hooks: a frame sent on several links is logged once)."""
        if self.failures.link_off and not force:
            return
        self._mav.seq = (self._mav.seq + 1) % 256
        sock, stats = self._sock, self.stats
        for addr in to:
            try:
                sock.sendto(buf, addr)
                stats.tx_messages += 1
            except OSError:
                stats.tx_errors += 1
        if tap:
            self._tap(buf)

    def _tap(self, frame: bytes) -> None:
        """Hand ``frame`` to the ``on_wire`` hooks; what one raises is recorded, and the vehicle flies on."""
        for hook in self.on_wire:
            try:
                hook(frame)
            except Exception as exc:
                self._hook_failed(hook, exc)

    def statustext(self, text: str, severity: int = MAV_SEVERITY_WARNING) -> None:
        """Send a STATUSTEXT to everyone (chunked when longer than 50 characters)."""
        with self._lock:
            self.statustexts.append((severity, text))
            raw = text.encode("utf-8", "replace")
            if len(raw) <= STATUSTEXT_LEN:
                self._send(self._mav.statustext_encode(severity, raw, 0, 0))
                return
            self._text_id = self._text_id % 0xFFFF + 1
            chunks = [raw[i : i + STATUSTEXT_LEN] for i in range(0, len(raw), STATUSTEXT_LEN)]
            if len(chunks[-1]) == STATUSTEXT_LEN:
                chunks.append(b"")
            for seq, chunk in enumerate(chunks[:256]):
                self._send(self._mav.statustext_encode(severity, chunk, self._text_id, seq))

    def _send_streams(self) -> None:
        """Send every stream that has fallen due (in simulated time) on each schedule; most ticks, none has."""
        now = self.sim.time_s
        builders, mav = self._builders, self._mav
        packed: dict[int, bytes] = {}
        for msg_id in self.streams.due(now):
            codec, fields = builders[msg_id]
            packed[msg_id] = buf = codec.pack(mav, fields())
            self._transmit(buf, self._destinations())
        for address, peer in self.links.peers.items():
            schedule = peer.schedule
            if schedule is None:
                continue
            for msg_id in schedule.due(now):
                frame = packed.get(msg_id)
                fresh = frame is None
                if frame is None:
                    codec, fields = builders[msg_id]
                    packed[msg_id] = frame = codec.pack(mav, fields())
                self._transmit(frame, (address,), tap=fresh)

    # -- message intervals (used by command handling, for the link the command came on) -------------------------

    def set_message_interval(self, message_id: int, interval_us: float) -> bool:
        """SET_MESSAGE_INTERVAL for the link in hand (the default rates, called in process): -1 stops the stream,
        0 restores the default, >0 sets it. False if not streamed."""
        if message_id not in self.streams.intervals_s:
            return False
        schedule = self.links.own_schedule(self._in_hand, self.streams)
        return schedule.set(message_id, interval_us, self.sim.time_s)

    def message_interval_us(self, message_id: int) -> int | None:
        """The stream's interval on the link in hand in µs, -1 when off, None when the message is not streamed."""
        return self.links.schedule_of(self._in_hand, self.streams).interval_us(message_id)

    def message_rate_hz(self, message_id: int, address: Address | None = None) -> float:
        """The stream's rate to ``address`` (the default rates when None; 0 when off or not streamed)."""
        return self.links.schedule_of(address, self.streams).rate_hz(message_id)

    def build_message(self, message_id: int, param2: float = math.nan) -> Any | None:
        """The message ``message_id`` as it would be sent now (for REQUEST_MESSAGE), or None if not available."""
        builder = self._builders.get(message_id)
        if builder is None:
            return None
        codec, fields = builder
        return codec.message(fields())

    def build_message_interval(self, message_id: int, interval_us: int) -> Any:
        return self._mav.message_interval_encode(message_id, interval_us)


__all__ = ["STATUSTEXT_LEN", "Sender"]
