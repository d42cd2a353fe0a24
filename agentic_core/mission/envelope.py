"""The flight envelope: every physical command is checked against the mission's limits after it is resolved —
templates filled in, ``target_id`` looked up, north/east turned into a place — and a command outside them is
refused before it leaves, with a reason the agent sees and can reflect on.

Checked: a destination (``lat``/``lon``, ``north_m``/``east_m`` from home, or ``target_id``) inside the geofence
(polygon or circle); an orbit's whole circle inside it; a landing place inside it; a take-off from where the
aircraft stands (``position``, else home) inside it; every altitude at most ``max_altitude_m`` and, but for take-off
and landing, at least the floor above home. Commands that name no place (hover, hold, rtl, the payload) pass.

>>> from agentic_core.contracts.policy_graph import Limits
>>> fence = Limits(geofence={"center": {"lat": 21.4133, "lon": 39.8933}, "radius_m": 200}, max_altitude_m=25)
>>> env = Envelope(fence, home=lambda: (21.4133, 39.8933))
>>> env.check("flight.fly_to", {"north_m": 100.0, "east_m": 0.0, "alt_m": 20.0})
[]
>>> env.check("flight.fly_to", {"north_m": 215.0, "east_m": 0.0, "alt_m": 30.0})
['the destination is 15 m outside the geofence', 'alt_m 30 m is above the ceiling of 25 m (limits.max_altitude_m)']
>>> Envelope(fence, home=lambda: (21.4133, 39.8933), position=lambda: (21.4163, 39.8933)).check("flight.takeoff", {})
['the aircraft stands 132 m outside the geofence: taking off there would break it at once']
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from ..contracts.geodesy import local_offset
from ..contracts.policy_graph import Circle, Limits
from ..contracts.polygon import distance_to_edge, outside_by

FLOOR_M = 2.0
"""The lowest a flight command may send the aircraft above home (take-off and landing aside)."""

Home = Callable[[], "tuple[float, float] | None"]
Resolve = Callable[[str], "tuple[float, float] | None"]
Problems = list[tuple[str, str]]
"""(the argument at fault, why) pairs."""


class Envelope:
    """The mission's limits as a check of resolved flight commands."""

    def __init__(
        self,
        limits: Limits | None,
        *,
        home: Home,
        targets: Resolve | None = None,
        floor_m: float = FLOOR_M,
        position: Home | None = None,
    ) -> None:
        self.limits = limits or Limits()
        self.home = home
        self.position = position  # where the aircraft is now (lat, lon); without it a take-off is from home
        self.targets = targets
        self.floor_m = floor_m
        self._fence: tuple[tuple[float, float], Any] | None = None  # (home, the fence in north/east metres)

    def check(self, tool: str, args: Mapping[str, Any]) -> list[str]:
        """Every limit ``tool(args)`` would break (empty: it may go)."""
        return [message for _, message in self.violations(tool, args)]

    def violations(self, tool: str, args: Mapping[str, Any]) -> list[tuple[str, str]]:
        """Every limit ``tool(args)`` would break, each with the argument that breaks it (``alt_m``, ``lat``,
        ``north_m``, ``target_id``, ``center``, ``radius_m``; ``position`` for where a take-off stands): what
        ``validate`` points a file's line at."""
        problems: list[tuple[str, str]] = []
        if tool == "flight.takeoff":
            standing = self._standing()
            outside = self._outside_by(standing) if standing is not None else 0.0
            if outside > 0:
                why = "taking off there would break it at once"
                problems.append(("position", f"the aircraft stands {outside:.0f} m outside the geofence: {why}"))
            self._altitude(args.get("altitude_m"), "altitude_m", problems, floor=False)
        elif tool == "flight.fly_to":
            self._place(args, self._destination(args, problems), "the destination", problems)
            self._altitude(args.get("alt_m"), "alt_m", problems)
        elif tool == "flight.orbit":
            centre = self._centre(args, problems)
            radius = _number(args.get("radius_m"))
            if centre is not None and radius is not None and self._circle_leaves(centre, radius):
                problems.append(("radius_m", f"the orbit of radius {radius:g} m leaves the geofence"))
            self._altitude(args.get("alt_m"), "alt_m", problems)
        elif tool == "flight.land" and (args.get("lat") is not None or args.get("target_id") is not None):
            place = self._destination(args, problems)
            self._place(args, place, "the landing place", problems)
            offset = _number(args.get("offset_m")) if args.get("target_id") is not None else None
            if place is not None and offset and self._outside_by(place) == 0 and self._circle_leaves(place, offset):
                problems.append(("offset_m", f"landing {offset:g} m from the target may leave the geofence"))
        return problems

    # ---- places, as north/east metres from home ----

    def _destination(self, args: Mapping[str, Any], problems: Problems) -> tuple[float, float] | None:
        lat, lon = _number(args.get("lat")), _number(args.get("lon"))
        if lat is not None and lon is not None:
            return self._local(lat, lon, problems)
        north, east = _number(args.get("north_m")), _number(args.get("east_m"))
        if north is not None and east is not None:
            return north, east
        target = args.get("target_id")
        if isinstance(target, str):
            found = self.targets(target) if self.targets is not None else None
            if found is None:
                why = f"target {target} is not in the world model: its place cannot be checked"
                problems.append(("target_id", why))
                return None
            return self._local(found[0], found[1], problems)
        return None

    def _standing(self) -> tuple[float, float] | None:
        """Where the aircraft is (north/east from home): its reported position, else home; None if unknown."""
        here = self.position() if self.position is not None else None
        if here is None:
            return (0.0, 0.0) if self.home() is not None else None
        return self._local(here[0], here[1], [])

    def _centre(self, args: Mapping[str, Any], problems: Problems) -> tuple[float, float] | None:
        centre = args.get("center")
        if isinstance(centre, Mapping):
            return self._destination({"lat": centre.get("lat"), "lon": centre.get("lon")}, problems)
        return self._destination({"target_id": args.get("target_id")}, problems)

    def _local(self, lat: float, lon: float, problems: Problems) -> tuple[float, float] | None:
        home = self.home()
        if home is None:
            problems.append(("lat", "the vehicle's home is not known yet: a place cannot be checked"))
            return None
        return local_offset(home[0], home[1], lat, lon)

    def _place(self, args: Mapping[str, Any], point: tuple[float, float] | None, what: str, problems: Problems) -> None:
        if point is None:
            return
        outside = self._outside_by(point)
        if outside > 0:
            field = next((f for f in ("lat", "north_m", "target_id", "center") if args.get(f) is not None), "lat")
            problems.append((field, f"{what} is {outside:.0f} m outside the geofence"))

    def _outside_by(self, point: tuple[float, float]) -> float:
        """How far ``point`` (north/east from home) lies outside the geofence; 0 inside or with no fence."""
        fence = self._local_fence()
        if fence is None:
            return 0.0
        if isinstance(fence, tuple):
            (north, east), radius = fence
            return max(0.0, math.hypot(point[0] - north, point[1] - east) - radius)
        return outside_by(point, fence)

    def _circle_leaves(self, centre: tuple[float, float], radius: float) -> bool:
        """Whether a circle (an orbit) reaches outside the fence: its centre outside, or nearer an edge than its
        radius (for a polygon, the disc around an inside point is inside while no edge is nearer than the radius)."""
        fence = self._local_fence()
        if fence is None:
            return False
        if isinstance(fence, tuple):
            (north, east), fence_radius = fence
            return math.hypot(centre[0] - north, centre[1] - east) + radius > fence_radius
        return outside_by(centre, fence) > 0 or float(distance_to_edge([centre], fence)[0]) < radius

    def _local_fence(self) -> tuple[tuple[float, float], float] | list[tuple[float, float]] | None:
        """The geofence in north/east metres from the vehicle's home (a circle's centre and radius, or a polygon's
        corners), worked out once per home; None without a fence or a home."""
        fence = self.limits.geofence
        home = self.home()
        if fence is None or home is None:
            return None
        if self._fence is None or self._fence[0] != home:
            local: tuple[tuple[float, float], float] | list[tuple[float, float]]
            if isinstance(fence, Circle):
                local = (
                    local_offset(home[0], home[1], float(fence.center.lat), float(fence.center.lon)),
                    fence.radius_m,
                )
            else:
                local = [local_offset(home[0], home[1], float(p.lat), float(p.lon)) for p in fence]
            self._fence = (home, local)
        return self._fence[1]

    # ---- heights ----

    def _altitude(self, value: Any, name: str, problems: Problems, *, floor: bool = True) -> None:
        height = _number(value)
        if height is None:
            return
        ceiling = self.limits.max_altitude_m
        if ceiling is not None and height > ceiling:
            problems.append(
                (name, f"{name} {height:g} m is above the ceiling of {ceiling:g} m (limits.max_altitude_m)")
            )
        if floor and height < self.floor_m:
            problems.append((name, f"{name} {height:g} m is below the floor of {self.floor_m:g} m above home"))


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


__all__ = ["FLOOR_M", "Envelope"]
