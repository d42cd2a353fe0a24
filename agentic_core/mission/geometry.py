"""Mission geometry on the WGS-84 tangent plane (:mod:`agentic_core.contracts.geodesy`): geofence containment and
lawnmower survey legs.

Areas a small UAV flies are a few kilometres across, so positions are projected onto the tangent plane at a
reference point; the error is far below GPS noise at that scale.
"""

from __future__ import annotations

from collections.abc import Sequence

from agentic_core.contracts.geodesy import local_offset, offset_position
from agentic_core.contracts.polygon import point_in_polygon

LatLonPoint = tuple[float, float]


def to_local(point: LatLonPoint, origin: LatLonPoint) -> tuple[float, float]:
    """(north_m, east_m) of ``point`` relative to ``origin``, on the WGS-84 tangent plane."""
    return local_offset(origin[0], origin[1], point[0], point[1])


def from_local(north: float, east: float, origin: LatLonPoint) -> LatLonPoint:
    """The point ``north``/``east`` metres from ``origin`` (the inverse of :func:`to_local`)."""
    return offset_position(origin[0], origin[1], north, east)


class Polygon:
    """A polygon projected once onto the local plane, for many containment tests."""

    def __init__(self, vertices: Sequence[LatLonPoint]) -> None:
        self.origin = vertices[0]
        self.local = [to_local(p, self.origin) for p in vertices]

    def contains(self, point: LatLonPoint) -> bool:
        """Whether ``point`` is inside (its edges count as inside: :mod:`agentic_core.contracts.polygon`)."""
        return point_in_polygon(to_local(point, self.origin), self.local)


def lawnmower(polygon: Sequence[LatLonPoint], spacing_m: float) -> list[LatLonPoint]:
    """Waypoints of a back-and-forth survey covering ``polygon``: lines running east-west, ``spacing_m`` apart,
    each clipped to the polygon, flown in alternating directions."""
    if len(polygon) < 3:
        raise ValueError("a survey polygon needs at least three points")
    if spacing_m <= 0:
        raise ValueError("survey spacing_m must be positive")
    origin = polygon[0]
    verts = [to_local(p, origin) for p in polygon]
    norths = [n for n, _ in verts]
    south, north = min(norths), max(norths)
    legs: list[LatLonPoint] = []
    line = 0
    y = south + spacing_m / 2
    while y <= north:
        xs = []
        for (n1, e1), (n2, e2) in zip(verts, verts[1:] + verts[:1], strict=True):
            if (n1 <= y < n2) or (n2 <= y < n1):
                xs.append(e1 + (y - n1) * (e2 - e1) / (n2 - n1))
        if len(xs) >= 2:
            west, east = min(xs), max(xs)
            ends = [(y, west), (y, east)] if line % 2 == 0 else [(y, east), (y, west)]
            legs.extend(from_local(n, e, origin) for n, e in ends)
            line += 1
        y += spacing_m
    return legs
