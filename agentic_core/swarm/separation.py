"""The separation actually flown: every UAV's position recorded on the swarm's shared clock while it is in the air,
and for every instant two were airborne together, how close they came. Losing separation is being closer than
both the horizontal and the vertical minimum at once (the rule :mod:`agentic_core.swarm.deconflict` plans by).

>>> log = SeparationLog(horizontal_m=15.0, vertical_m=8.0)
>>> log.record("a", 1.0, Point(north=0, east=0, alt=30))
>>> log.record("b", 1.0, Point(north=5, east=0, alt=40))
>>> report = log.report()
>>> report["min_distance_m"], report["losses"]
(11.18, 0)
>>> log.record("b", 1.1, Point(north=5, east=0, alt=33)); log.record("a", 1.1, Point(north=0, east=0, alt=30))
>>> log.report()["losses"]
1
"""

from __future__ import annotations

import threading
from typing import Any

from agentic_core.contracts.swarm import Point

GRID_S = 0.1
"""Positions are kept on this grid of the shared clock (every vehicle ticks the same steps, so instants match)."""


class SeparationLog:
    """Positions by instant (thread-safe: each vehicle's samples arrive in the clock's thread)."""

    def __init__(self, *, horizontal_m: float, vertical_m: float) -> None:
        self.horizontal_m = horizontal_m
        self.vertical_m = vertical_m
        self._at: dict[int, dict[str, Point]] = {}
        self._lock = threading.Lock()

    def record(self, uav: str, time_s: float, where: Point) -> None:
        """``uav`` was at ``where`` at ``time_s`` (only the first sample in each grid cell is kept)."""
        slot = round(time_s / GRID_S)
        if abs(slot * GRID_S - time_s) > 1e-6:
            return
        with self._lock:
            self._at.setdefault(slot, {}).setdefault(uav, where)

    def report(self) -> dict[str, Any]:
        """The closest two airborne UAVs came (metres, who, when), and the instants separation was lost."""
        with self._lock:
            instants = sorted((slot, dict(seen)) for slot, seen in self._at.items() if len(seen) > 1)
        best: tuple[float, str, str, float] | None = None
        losses = 0
        for slot, seen in instants:
            names = sorted(seen)
            for i, a in enumerate(names):
                for b in names[i + 1 :]:
                    pa, pb = seen[a], seen[b]
                    d = pa.distance_to(pb)
                    if best is None or d < best[0]:
                        best = (d, a, b, slot * GRID_S)
                    if pa.horizontal_to(pb) < self.horizontal_m and abs(pa.alt - pb.alt) < self.vertical_m:
                        losses += 1
        return {
            "min_distance_m": round(best[0], 2) if best else None,
            "closest": [best[1], best[2]] if best else [],
            "at_s": round(best[3], 2) if best else None,
            "losses": losses,
            "horizontal_m": self.horizontal_m,
            "vertical_m": self.vertical_m,
            "instants": len(instants),
        }


__all__ = ["GRID_S", "SeparationLog"]
