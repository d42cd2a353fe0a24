"""The vehicle's links, one per peer address, kept as PX4 keeps its links: rates, liveness and who commands.

Why: one rate table and one peer list shared by everybody let any local socket silence the ground station's
telemetry (one SET_MESSAGE_INTERVAL), push it out of the peer table (20 chattering sockets) or keep the data-link
failsafe from firing (a quadrotor's heartbeat). Here:

* :class:`StreamSchedule` is a table of stream intervals. The vehicle's default one serves every link until a
  peer's SET_MESSAGE_INTERVAL gives that peer a copy of its own (PX4 keeps one per link), so a peer changes only
  what it receives.
* :class:`LinkTable` keeps at most :data:`MAX_PEERS` peers, the least recently heard dropped first, but never the
  *commanding ground station* and, while others can go, never a peer that has signed a message with the key.
* The commanding ground station is the first peer whose HEARTBEAT says MAV_TYPE_GCS (signed, when signing is on);
  it stays so, bound to its address and system id, until it has been silent for the data-link timeout. Only its
  heartbeats feed the data-link failsafe; a heartbeat claiming its system id from another address is not its
  (counted in :attr:`LinkTable.impostors`).

>>> rates = StreamSchedule({0: 1.0})
>>> rates.due(0.0), rates.due(0.5), rates.due(1.0), rates.set(0, -1, 1.0), rates.due(2.0)
([0], [], [0], True, [])
>>> table = LinkTable(max_peers=2)
>>> _ = table.gcs_heartbeat(("127.0.0.1", 1), 255, 0.0, 10.0)
>>> for port in (1, 2, 3, 4):
...     _ = table.heard(("127.0.0.1", port), 0.0, 255, 190, False)
>>> list(table.peers), table.evicted
([('127.0.0.1', 1), ('127.0.0.1', 4)], 2)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

Address = tuple[str, int]

MAX_PEERS = 16

_EPS = 1e-9


class StreamSchedule:
    """Stream intervals (s; 0 off) and when each falls due next, on the simulated clock."""

    def __init__(self, intervals_s: dict[int, float], defaults_s: dict[int, float] | None = None) -> None:
        self.intervals_s = dict(intervals_s)
        self.defaults_s = dict(intervals_s if defaults_s is None else defaults_s)
        self.next_due = dict.fromkeys(self.intervals_s, 0.0)
        self.due_s = 0.0
        """The earliest time any enabled stream falls due (inf: none enabled)."""

    def copy(self) -> StreamSchedule:
        twin = StreamSchedule(self.intervals_s, self.defaults_s)
        twin.next_due = dict(self.next_due)
        twin.due_s = self.due_s
        return twin

    def set(self, message_id: int, interval_us: float, now_s: float) -> bool:
        """SET_MESSAGE_INTERVAL: -1 stops the stream, 0 restores the default, >0 sets it. False if not streamed."""
        if message_id not in self.intervals_s:
            return False
        if interval_us == -1:
            self.intervals_s[message_id] = 0.0
        elif interval_us == 0:
            self.intervals_s[message_id] = self.defaults_s[message_id]
        elif interval_us > 0:
            self.intervals_s[message_id] = interval_us / 1e6
        else:
            return False
        self.next_due[message_id] = self.due_s = now_s
        return True

    def restart(self, now_s: float) -> None:
        """Every stream falls due now (after the intervals were replaced wholesale, e.g. by a snapshot)."""
        for msg_id in self.next_due:
            self.next_due[msg_id] = now_s
        self.due_s = now_s

    def interval_us(self, message_id: int) -> int | None:
        """The stream's interval in µs, -1 when off, None when the message is not streamed."""
        if message_id not in self.intervals_s:
            return None
        interval = self.intervals_s[message_id]
        return round(interval * 1e6) if interval > 0 else -1

    def rate_hz(self, message_id: int) -> float:
        interval = self.intervals_s.get(message_id, 0.0)
        return 1.0 / interval if interval > 0 else 0.0

    def due(self, now_s: float) -> list[int]:
        """The streams due now, in table order; each one's next time is set. Most ticks: none (cheap)."""
        if now_s + _EPS < self.due_s:
            return []
        out: list[int] = []
        next_due = self.next_due
        soonest = math.inf
        for msg_id, interval in self.intervals_s.items():
            if interval <= 0:
                continue
            due = next_due[msg_id]
            if now_s + _EPS >= due:
                out.append(msg_id)
                due += interval
                due = next_due[msg_id] = due if due > now_s + _EPS else now_s + interval
            if due < soonest:
                soonest = due
        self.due_s = soonest
        return out


@dataclass(slots=True)
class Peer:
    """One address that has sent the vehicle a message it accepted."""

    address: Address
    heard_s: float
    """Simulated time of its last accepted message."""
    system_id: int = 0
    component_id: int = 0
    signed: bool = False
    """It has sent a message signed with the vehicle's key."""
    schedule: StreamSchedule | None = None
    """Its own stream rates (None: the vehicle's defaults)."""
    rx_messages: int = 0


@dataclass(slots=True)
class LinkTable:
    """The peers, the commanding ground station and the counters of eviction and impostors."""

    max_peers: int = MAX_PEERS
    peers: dict[Address, Peer] = field(default_factory=dict)
    """Most recently heard last."""
    commander: tuple[Address, int] | None = None
    """(address, system id) of the commanding ground station."""
    commander_heard: float | None = None
    """When its last heartbeat came, on the vehicle's link clock."""
    evicted: int = 0
    impostors: int = 0
    version: int = 0
    """Bumped whenever the set of peers or their schedules change (destinations are cached on it)."""

    def heard(self, address: Address, now_s: float, system_id: int, component_id: int, signed: bool) -> Peer:
        """Record an accepted message from ``address``; the peer becomes the most recent, others may be dropped."""
        peers = self.peers
        peer = peers.get(address)
        if peer is None:
            peer = Peer(address, now_s)
            peers[address] = peer
            self.version += 1
            self._evict()
        elif next(reversed(peers)) != address:
            del peers[address]
            peers[address] = peer  # most recent last; destinations keep their order (version unchanged)
        peer.heard_s = now_s
        peer.system_id, peer.component_id = system_id, component_id
        peer.signed = peer.signed or signed
        peer.rx_messages += 1
        return peer

    def _evict(self) -> None:
        while len(self.peers) > self.max_peers:
            keep = self.commander[0] if self.commander else None
            candidates = [a for a in self.peers if a != keep]
            unsigned = [a for a in candidates if not self.peers[a].signed]
            victim = (unsigned or candidates)[0]
            del self.peers[victim]
            self.evicted += 1

    def gcs_heartbeat(self, address: Address, system_id: int, now: float, lost_after_s: float) -> bool:
        """A ground station's HEARTBEAT (already judged acceptable); whether it counts as the commander's."""
        if self.commander is None or self.commander_heard is None or now - self.commander_heard > lost_after_s:
            self.commander = (address, system_id)
        if self.commander != (address, system_id):
            if self.commander[1] == system_id:
                self.impostors += 1
            return False
        self.commander_heard = now
        return True

    def is_commander(self, address: Address, system_id: int) -> bool:
        return self.commander == (address, system_id)

    def schedule_of(self, address: Address | None, default: StreamSchedule) -> StreamSchedule:
        """The rates ``address`` receives (the default when it has none of its own, or is not a peer)."""
        peer = self.peers.get(address) if address is not None else None
        return default if peer is None or peer.schedule is None else peer.schedule

    def own_schedule(self, address: Address | None, default: StreamSchedule) -> StreamSchedule:
        """``address``'s own rates, copied from the default on first use (the default for no peer)."""
        peer = self.peers.get(address) if address is not None else None
        if peer is None:
            return default
        if peer.schedule is None:
            peer.schedule = default.copy()
            self.version += 1
        return peer.schedule


__all__ = ["MAX_PEERS", "LinkTable", "Peer", "StreamSchedule"]
