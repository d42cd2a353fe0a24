"""Liveness among the UAVs once the ground is lost: each UAV sends a signed ``heartbeat`` to every peer on the
swarm's clock, each peer's :class:`~agentic_core.swarm.signing.Guard` checks it (a forged, replayed, stale or
misaddressed one is refused and audited, and counts for nothing), and a UAV no live peer has heard for longer than
the timeout is judged failed — by the messages, not by anyone's memory of its vehicle.

Why: without the ground nobody sees every vehicle; what a UAV knows of another is what it hears from it.

>>> from agentic_core.swarm.signing import Guard, SwarmKey
>>> key, now = SwarmKey.generate("mina"), [0.0]
>>> beats = Heartbeats(key, {u: Guard(key, u) for u in ("a", "b")}, clock=lambda: now[0], timeout_s=5.0)
>>> beats.start(["a", "b"])
>>> now[0] = 4.0; beats.beat("a")
>>> now[0] = 8.0
>>> beats.alive("a", among=["a", "b"]), beats.alive("b", among=["a", "b"])
(True, False)
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Mapping

from agentic_core.swarm.signing import Guard, Refused, Sealer, SwarmKey

NEVER = float("-inf")


class Heartbeats:
    """Signed heartbeats among the UAVs (see the module docstring). ``deliver(to, raw)`` carries one as JSON to the
    peer ``to`` (default: straight to its guard, :meth:`hear`); a test may tamper with it on the way."""

    def __init__(
        self,
        key: SwarmKey,
        guards: Mapping[str, Guard],
        *,
        clock: Callable[[], float],
        period_s: float = 1.0,
        timeout_s: float = 10.0,
        deliver: Callable[[str, str], bool] | None = None,
    ) -> None:
        self.guards = guards
        self.sealers = {uav: Sealer(key, uav) for uav in guards}
        self.clock = clock
        self.period_s = period_s
        self.timeout_s = timeout_s
        self.deliver = deliver or self.hear
        self.heard: dict[str, dict[str, float]] = {uav: {} for uav in guards}
        """Receiver → sender → the swarm's time its last heartbeat was accepted."""
        self.started_at: float | None = None
        self._sent: dict[str, float] = {}
        self._lock = threading.Lock()

    def start(self, alive: Iterable[str]) -> None:
        """Start (the ground is lost): the UAVs ``alive`` now count as just heard by everyone; any other, never."""
        now = self.clock()
        with self._lock:
            if self.started_at is not None:
                return
            self.started_at = now
            live = set(alive)
            for receiver, heard in self.heard.items():
                heard.update({sender: now for sender in live if sender != receiver})

    def beat(self, uav: str) -> None:
        """``uav`` is alive (its own thread says so: a sample from its vehicle): a heartbeat to every peer when one
        is due on the swarm's clock. Nothing before :meth:`start`."""
        if self.started_at is None:  # every sample of every UAV comes here: the ground still judges
            return
        now = self.clock()
        with self._lock:
            if self.started_at is None or now - self._sent.get(uav, NEVER) < self.period_s:
                return
            self._sent[uav] = now
        sealer = self.sealers[uav]
        for peer in self.guards:
            if peer != uav:
                message = sealer.seal("heartbeat", {"t": round(now, 3)}, recipient=peer, conversation="heartbeat")
                self.deliver(peer, message.model_dump_json())

    def hear(self, receiver: str, raw: str) -> bool:
        """A heartbeat off the wire at ``receiver``: its guard checks it; whether it was accepted."""
        try:
            message = self.guards[receiver].parse(raw)
        except Refused:
            return False
        if message.kind != "heartbeat" or message.sender == receiver or message.sender not in self.heard:
            return False
        with self._lock:
            self.heard[receiver][message.sender] = self.clock()
        return True

    def silent_s(self, uav: str, among: Iterable[str]) -> float:
        """Seconds of the swarm's clock since any of ``among`` (but ``uav``) last accepted a heartbeat from ``uav``."""
        with self._lock:
            last = max((self.heard[r].get(uav, NEVER) for r in among if r != uav and r in self.heard), default=NEVER)
        return self.clock() - last

    def alive(self, uav: str, among: Iterable[str]) -> bool:
        """Whether ``uav`` was heard by one of ``among`` within the timeout (alone, it answers for itself)."""
        others = [r for r in among if r != uav]
        return not others or self.silent_s(uav, others) <= self.timeout_s


__all__ = ["Heartbeats"]
