"""The geofence: PX4's cylinder around home plus the polygons and circles uploaded as a fence plan.

Why: one answer to "is this point allowed?" for everything that must respect the fence: the navigator refusing a
command or an offboard setpoint, the mission feasibility check refusing a plan, and the failsafe acting on a breach
(:mod:`flight.mavlink.failsafe`). The cylinder comes from the ``GF_MAX_HOR_DIST`` / ``GF_MAX_VER_DIST`` parameters
(read at each check, so a PARAM_SET applies at once); the areas come from the fence plan
(:meth:`Geofence.from_items`, rebuilt on every fence upload or clear).

Behaviour kept from PX4 (MAVLink ``common.xml`` for the items; the PX4 user guide, "GeoFence", for the rule):

* MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION 5001/5002: consecutive vertices form one polygon, each
  with param1 = the number of vertices; MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION 5003/5004: param1 is the
  radius, x/y the centre. NAV_FENCE_RETURN_POINT 5000 is stored and ignored here.
* A point is allowed when it is inside at least one inclusion area (if there is any) and outside every exclusion
  area; the inclusion groups of param2 are not distinguished (every inclusion area is one group).
* Fence areas are horizontal only; the height limit is ``GF_MAX_VER_DIST``.

Positions are north/east metres from home on the tangent plane (:mod:`agentic_core.contracts.geodesy`), good
over the few kilometres a fence spans. A polygon whose vertices do not come in complete runs of param1 is refused
(:class:`FenceInvalid`; ours, PX4 discards such a fence when loading it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
)

from agentic_core.contracts.errors import AgenticUAVError
from agentic_core.contracts.geodesy import local_offset
from agentic_core.contracts.polygon import point_in_polygon
from flight.mavlink.mission_items import (
    FENCE_CIRCLE_COMMANDS,
    FENCE_POLYGON_COMMANDS,
    StoredItem,
    vertex_count,
)
from flight.mavlink.params import ParamStore

Point = tuple[float, float]


class FenceInvalid(AgenticUAVError, ValueError):
    """A fence plan that does not describe areas (a polygon's vertex runs do not add up)."""


@dataclass(frozen=True, slots=True)
class Polygon:
    vertices: tuple[Point, ...]
    """(north, east) metres from home, in order."""
    inclusion: bool

    def contains(self, north: float, east: float) -> bool:
        """Even-odd, a point on an edge inside (:mod:`agentic_core.contracts.polygon`)."""
        return point_in_polygon((north, east), self.vertices)


@dataclass(frozen=True, slots=True)
class Circle:
    centre: Point
    radius_m: float
    inclusion: bool

    def contains(self, north: float, east: float) -> bool:
        return math.hypot(north - self.centre[0], east - self.centre[1]) <= self.radius_m  # as points_in_circle


Area = Polygon | Circle


class Geofence:
    """The fence the vehicle enforces: ``params``' cylinder and ``areas`` from a fence plan."""

    def __init__(self, params: ParamStore, areas: Sequence[Area] = ()) -> None:
        self.params = params
        self.areas: tuple[Area, ...] = tuple(areas)

    @staticmethod
    def areas_from_items(items: Sequence[StoredItem], home_lat: float, home_lon: float) -> tuple[Area, ...]:
        """The areas a fence plan describes, in metres from home; raises :class:`FenceInvalid`."""
        areas: list[Area] = []
        i = 0
        while i < len(items):
            item = items[i]
            if item.command in FENCE_POLYGON_COMMANDS:
                count = vertex_count(item)
                run = items[i : i + count]
                if len(run) < count or any(v.command != item.command or vertex_count(v) != count for v in run):
                    raise FenceInvalid(f"fence polygon at item {i} does not have its {count} vertices in a row")
                vertices = tuple(local_offset(home_lat, home_lon, v.x, v.y) for v in run)
                areas.append(Polygon(vertices, item.command == MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION))
                i += count
                continue
            if item.command in FENCE_CIRCLE_COMMANDS:
                centre = local_offset(home_lat, home_lon, item.x, item.y)
                areas.append(Circle(centre, item.params[0], item.command == MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION))
            i += 1
        return tuple(areas)

    def violation(self, north: float, east: float, alt_m: float) -> str | None:
        """Why the point (metres from home, altitude above home) is outside the fence, or None if allowed."""
        max_h, max_v = self.params["GF_MAX_HOR_DIST"], self.params["GF_MAX_VER_DIST"]
        dist = math.hypot(north, east)
        if max_h > 0 and dist > max_h:
            return f"{dist:.0f} m from home is outside the {max_h:.0f} m fence"
        if max_v > 0 and alt_m > max_v:
            return f"{alt_m:.1f} m is above the {max_v:.0f} m ceiling"
        return self.area_violation(north, east)

    def area_violation(self, north: float, east: float) -> str | None:
        """Why the point is outside the uploaded fence areas, or None (also None when there are none)."""
        if not self.areas:  # the usual case, checked every tick
            return None
        inclusions = [a for a in self.areas if a.inclusion]
        if inclusions and not any(a.contains(north, east) for a in inclusions):
            return "outside the uploaded inclusion fence"
        if any(a.contains(north, east) for a in self.areas if not a.inclusion):
            return "inside an uploaded exclusion fence"
        return None
