"""The swarm's book of legs: one :class:`~agentic_core.swarm.deconflict.Airspace` shared by every UAV's tools, on
the swarm clock's time base, under one lock, with every decision written down — a leg granted (in the layer
asked, another, or later: ``delay_s``), refused (no layer and no start within the airspace's delay keeps the
separation) and every UAV's reservations released (it landed for good or died). A hold where a UAV is (between
legs, hovering) is reserved too, always granted; one that clashes (the aircraft strayed from its plan) is noted.

>>> records = []
>>> book = LegBook(Airspace(layers=(30.0, 40.0)), clock=lambda: 0.0, record=lambda e, **f: records.append((e, f)))
>>> book.prefer("a", 30.0); book.prefer("b", 30.0)
>>> grant = book.request("a", Point(north=0, east=0), Point(north=100, east=0), tool="flight.fly_to")
>>> grant.layer_m, grant.delay_s
(30.0, 0.0)
>>> book.request("b", Point(north=100, east=0), Point(north=0, east=0), tool="flight.fly_to", asked_m=30.0).layer_m
40.0
>>> [f["decision"] for e, f in records]
['granted', 'relayered']
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from agentic_core.contracts.swarm import Point
from agentic_core.swarm.deconflict import Airspace, NoSafeLeg, Trajectory

__all__ = ["Grant", "LegBook", "NoSafeLeg", "Record"]


class Record(Protocol):
    """Writes one line of ``swarm.jsonl`` (the coordinator's ``_record``)."""

    def __call__(self, event: str, **fields: Any) -> None: ...


@dataclass(frozen=True)
class Grant:
    """A leg granted: the reserved trajectory, its layer, and how long the UAV holds where it is before going."""

    trajectory: Trajectory
    layer_m: float
    delay_s: float

    @property
    def go_s(self) -> float:
        """When the UAV may leave where it is (the swarm's clock)."""
        return self.trajectory.start + self.delay_s

    def reached_s(self, index: int) -> float:
        """When the plan has it at its ``index``-th waypoint after the start."""
        return self.trajectory.waypoints[min(index, len(self.trajectory.waypoints) - 1)][0]


def _xyz(p: Point) -> list[float]:
    return [round(p.north, 1), round(p.east, 1), round(p.alt, 1)]


class LegBook:
    """See the module docstring. ``clock`` is the swarm's (simulated seconds); ``record`` writes a line."""

    def __init__(self, airspace: Airspace, *, clock: Callable[[], float], record: Record) -> None:
        self.airspace = airspace
        self.clock = clock
        self.record = record
        self._lock = threading.Lock()
        self.counts = {"granted": 0, "relayered": 0, "delayed": 0, "refused": 0, "released": 0, "strayed": 0}
        self.lost: set[str] = set()
        """UAVs released for good (dead): nothing of theirs is reserved again."""

    def prefer(self, uav: str, layer_m: float) -> None:
        """``uav``'s own layer, tried first (ignored if the airspace has no such layer)."""
        with self._lock:
            if layer_m in self.airspace.layers:
                self.airspace.prefer(uav, layer_m)

    def request(
        self, uav: str, start: Point, goal: Point, *, tool: str, land: bool = False, asked_m: float | None = None
    ) -> Grant:
        """Reserve ``uav``'s leg from ``start`` to ``goal`` now; the grant, or :class:`NoSafeLeg` (both written)."""
        with self._lock:
            t0 = self.clock()
            fields: dict[str, Any] = {"uav": uav, "tool": tool, "start": _xyz(start), "goal": _xyz(goal)}
            try:
                if uav in self.lost:
                    raise NoSafeLeg(f"{uav} is lost: its airspace was released")
                trajectory = self.airspace.reserve(uav, start, goal, t0=t0, land=land)
            except NoSafeLeg as refused:
                self._count("leg", decision="refused", why=str(refused), **fields)
                raise
            delay = max(t for t, p in trajectory.waypoints if p == start) - t0
            points = [p for _, p in trajectory.waypoints]
            layer = points[-2].alt if land and len(points) > 1 else points[-1].alt
            if delay > 0:
                decision = "delayed"
            elif asked_m is not None and abs(asked_m - layer) > 0.5:
                decision = "relayered"
            else:
                decision = "granted"
            end = trajectory.waypoints[-1][0]
            self._count("leg", decision=decision, layer_m=layer, asked_m=asked_m, delay_s=round(delay, 2),
                        until_s=round(end, 2), **fields)  # fmt: skip
            return Grant(trajectory, layer, delay)

    def hold(self, uav: str, where: Point) -> None:
        """``uav`` holds at ``where`` from now on (until its next leg)."""
        with self._lock:
            if uav in self.lost:
                return
            clash = self.airspace.hold(uav, where, t0=self.clock())
            if clash:
                self._count("leg", decision="strayed", uav=uav, at=_xyz(where), clash=clash)

    def release(self, uav: str, why: str, *, lost: bool = False) -> None:
        """Drop ``uav``'s reservations (written if it had any); ``lost``: for good, it reserves nothing again."""
        with self._lock:
            if lost:
                self.lost.add(uav)
            dropped = self.airspace.release(uav)
            if dropped:
                self._count("airspace_released", decision="released", uav=uav, why=why, legs=dropped)

    def _count(self, event: str, **fields: Any) -> None:
        self.counts[fields["decision"]] += 1
        self.record(event, **fields)
