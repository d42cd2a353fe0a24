"""Deconfliction by altitude layers and a space-time reservation of every leg: before a UAV flies a leg it reserves
it — climb (or descend) to a layer over where it is, cruise to the goal in that layer, hold there — and a leg is
granted only if, at every instant, it keeps the configured separation from every leg other UAVs hold (closer than
``horizontal_m`` and ``vertical_m`` at once is a loss of separation). Its own layer first, then the others, then
later starts: the first safe plan wins; none within ``max_delay_s`` is :class:`NoSafeLeg`.

Trajectories are piecewise linear in time, so the check is exact, not sampled: on each piece both aircraft move
linearly and the times of a horizontal and of a vertical conflict are each one interval, solved in closed form.

>>> airspace = Airspace(layers=(30.0, 45.0), horizontal_m=20.0, vertical_m=10.0)
>>> a = airspace.reserve("a", Point(north=0, east=0, alt=0), Point(north=200, east=0), t0=0.0)
>>> b = airspace.reserve("b", Point(north=200, east=0, alt=0), Point(north=0, east=0), t0=0.0)
>>> a.waypoints[-1][1].alt, b.waypoints[-1][1].alt
(30.0, 45.0)
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import pairwise

from agentic_core.contracts.errors import AgenticUAVError
from agentic_core.contracts.swarm import Point

Waypoint = tuple[float, Point]


class NoSafeLeg(AgenticUAVError):
    """No layer and no start within the allowed delay keeps the separation."""


@dataclass(frozen=True)
class Trajectory:
    """Where one UAV will be: waypoints (time, place), linear between them; it holds at the last until ``until``."""

    uav: str
    waypoints: tuple[Waypoint, ...]
    until: float

    def at(self, t: float) -> Point:
        """Where it is at time ``t`` (at its first point before, at its last after)."""
        points = self.waypoints
        if t <= points[0][0]:
            return points[0][1]
        for (ta, pa), (tb, pb) in pairwise(points):
            if t <= tb:
                f = 0.0 if tb == ta else (t - ta) / (tb - ta)
                return Point(
                    north=pa.north + f * (pb.north - pa.north),
                    east=pa.east + f * (pb.east - pa.east),
                    alt=pa.alt + f * (pb.alt - pa.alt),
                )
        return points[-1][1]

    @property
    def start(self) -> float:
        """When it begins."""
        return self.waypoints[0][0]

    def breakpoints(self) -> list[float]:
        """Every time its motion changes, and its end."""
        return [t for t, _ in self.waypoints] + [self.until]


def conflict(a: Trajectory, b: Trajectory, horizontal_m: float, vertical_m: float) -> float | None:
    """The first time ``a`` and ``b`` are closer than both limits at once while both are reserved, or None."""
    lo, hi = max(a.start, b.start), min(a.until, b.until)
    if lo > hi:
        return None
    times = sorted({lo, hi, *(t for t in a.breakpoints() + b.breakpoints() if lo < t < hi)})
    for t0, t1 in pairwise(times):
        hit = _piece_conflict(a.at(t0), a.at(t1), b.at(t0), b.at(t1), t1 - t0, horizontal_m, vertical_m)
        if hit is not None:
            return t0 + hit
    if len(times) == 1:
        return _piece_conflict(a.at(lo), a.at(lo), b.at(lo), b.at(lo), 0.0, horizontal_m, vertical_m)
    return None


def _piece_conflict(
    a0: Point, a1: Point, b0: Point, b1: Point, span: float, horizontal_m: float, vertical_m: float
) -> float | None:
    """Within one linear piece of length ``span``: the first offset where both distances are under their limits."""
    dn, de, dz = a0.north - b0.north, a0.east - b0.east, a0.alt - b0.alt
    vn = (a1.north - b1.north) - dn
    ve = (a1.east - b1.east) - de
    vz = (a1.alt - b1.alt) - dz
    horizontal = _below_quadratic(vn * vn + ve * ve, 2 * (dn * vn + de * ve), dn * dn + de * de - horizontal_m**2)
    vertical = _below_linear(vz, dz, vertical_m)
    if horizontal is None or vertical is None:
        return None
    start, end = max(horizontal[0], vertical[0], 0.0), min(horizontal[1], vertical[1], 1.0)
    return start * span if start < end or (start == end and span == 0.0) else None


def _below_quadratic(a: float, b: float, c: float) -> tuple[float, float] | None:
    """Where a·s² + b·s + c < 0 (a ≥ 0), as an interval of s, or None."""
    if a < 1e-12:
        if abs(b) < 1e-12:
            return (-math.inf, math.inf) if c < 0 else None
        root = -c / b
        return (-math.inf, root) if b > 0 else (root, math.inf)
    disc = b * b - 4 * a * c
    if disc <= 0:
        return None
    r = math.sqrt(disc)
    return ((-b - r) / (2 * a), (-b + r) / (2 * a))


def _below_linear(v: float, d: float, limit: float) -> tuple[float, float] | None:
    """Where |d + v·s| < limit, as an interval of s, or None."""
    if abs(v) < 1e-12:
        return (-math.inf, math.inf) if abs(d) < limit else None
    s1, s2 = (-limit - d) / v, (limit - d) / v
    return (min(s1, s2), max(s1, s2))


@dataclass
class Airspace:
    """The reservations of a swarm's legs, and the rules that grant them."""

    layers: Sequence[float] = (30.0, 40.0, 50.0, 60.0)
    horizontal_m: float = 15.0
    vertical_m: float = 8.0
    speed_mps: float = 8.0
    climb_mps: float = 2.0
    descent_mps: float | None = None
    """How fast a leg that lands comes down (None: ``climb_mps``)."""
    hold_s: float = 120.0
    delay_step_s: float = 5.0
    max_delay_s: float = 120.0

    def __post_init__(self) -> None:
        self.reserved: dict[str, list[Trajectory]] = {}
        self._home_layer: dict[str, int] = {}

    def prefer(self, uav: str, layer_m: float) -> None:
        """Make ``layer_m`` (one of :attr:`layers`) the layer ``uav``'s legs try first."""
        self._home_layer[uav] = list(self.layers).index(layer_m)

    def reserve(self, uav: str, start: Point, goal: Point, *, t0: float, land: bool = False) -> Trajectory:
        """Reserve ``uav``'s leg from ``start`` to over ``goal`` (flown in a layer) from ``t0``; the plan granted.
        With ``land`` the leg ends coming down over ``goal`` to its ``alt``.

        Its previous reservation's hold ends at ``t0``."""
        self._home_layer.setdefault(uav, len(self._home_layer) % len(self.layers))
        others = [t for u, legs in self.reserved.items() if u != uav for t in legs]
        for candidate in self._candidates(uav, start, goal, t0, land):
            if all(conflict(candidate, o, self.horizontal_m, self.vertical_m) is None for o in others):
                self._cut(uav, t0)
                self.reserved.setdefault(uav, []).append(candidate)
                return candidate
        raise NoSafeLeg(
            f"{uav}: no layer of {list(self.layers)} and no start within {self.max_delay_s:g} s of t={t0:g} "
            f"keeps {self.horizontal_m:g} m / {self.vertical_m:g} m from the other legs"
        )

    def hold(self, uav: str, where: Point, *, t0: float) -> list[str]:
        """Reserve ``uav`` holding at ``where`` from ``t0`` (where it is: always granted, its previous hold ended);
        the UAVs whose legs it conflicts with (none, unless the aircraft strayed from its plan)."""
        mine = Trajectory(uav, ((t0, where),), until=t0 + self.hold_s)
        clash = sorted(
            {u for u, legs in self.reserved.items() if u != uav for t in legs
             if conflict(mine, t, self.horizontal_m, self.vertical_m) is not None}
        )  # fmt: skip
        self._cut(uav, t0)
        self.reserved.setdefault(uav, []).append(mine)
        return clash

    def release(self, uav: str) -> int:
        """Drop every reservation of ``uav`` (it has landed for good, or died); how many there were."""
        return len(self.reserved.pop(uav, []))

    def _cut(self, uav: str, t0: float) -> None:
        legs = self.reserved.get(uav, [])
        if legs and legs[-1].until > t0:
            legs[-1] = replace(legs[-1], until=max(t0, legs[-1].waypoints[-1][0]))

    def _candidates(self, uav: str, start: Point, goal: Point, t0: float, land: bool) -> Iterator[Trajectory]:
        home = self._home_layer[uav]
        order = [self.layers[(home + i) % len(self.layers)] for i in range(len(self.layers))]
        steps = int(self.max_delay_s / self.delay_step_s)
        for k in range(steps + 1):
            for alt in order:
                yield self._plan(uav, start, goal, alt, t0, k * self.delay_step_s, land)

    def _plan(
        self, uav: str, start: Point, goal: Point, alt: float, t0: float, delay: float, land: bool = False
    ) -> Trajectory:
        up = Point(north=start.north, east=start.east, alt=alt)
        over = Point(north=goal.north, east=goal.east, alt=alt)
        t_go = t0 + delay
        t_up = t_go + abs(alt - start.alt) / self.climb_mps
        t_over = t_up + start.horizontal_to(goal) / self.speed_mps
        points: list[Waypoint] = [(t0, start), (t_go, start), (t_up, up), (t_over, over)]
        if land:
            points.append((t_over + abs(alt - goal.alt) / (self.descent_mps or self.climb_mps), goal))
        kept = [points[0]] + [p for prev, p in pairwise(points) if p[0] > prev[0]]
        return Trajectory(uav, tuple(kept), until=kept[-1][0] + self.hold_s)


def min_separation(tracks: Mapping[str, Sequence[Waypoint]]) -> tuple[float, str, str, float] | None:
    """The closest two UAVs came in flown tracks sampled on a shared clock: (metres, uav, uav, time), or None."""
    best: tuple[float, str, str, float] | None = None
    names = sorted(tracks)
    for i, a in enumerate(names):
        at_a = dict(tracks[a])
        for b in names[i + 1 :]:
            for t, pb in tracks[b]:
                pa = at_a.get(t)
                if pa is not None and (best is None or pa.distance_to(pb) < best[0]):
                    best = (pa.distance_to(pb), a, b, t)
    return best


__all__ = ["Airspace", "NoSafeLeg", "Trajectory", "conflict", "min_separation"]
