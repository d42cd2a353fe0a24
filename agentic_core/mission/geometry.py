"""Mission geometry on the WGS-84 tangent plane (:mod:`agentic_core.contracts.geodesy`): geofence containment and
lawnmower survey legs.

Areas a small UAV flies are a few kilometres across, so positions are projected onto the tangent plane at a
reference point; the error is far below GPS noise at that scale.
"""

from __future__ import annotations

from collections.abc import Sequence

from agentic_core.contracts.geodesy import local_offset, offset_position

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
        self.edges = list(zip(self.local, self.local[1:] + self.local[:1], strict=True))

    def contains(self, point: LatLonPoint) -> bool:
        """Ray casting on the local plane; points on an edge count as inside."""
        x, y = to_local(point, self.origin)
        inside = False
        for (x1, y1), (x2, y2) in self.edges:
            if min(y1, y2) <= y <= max(y1, y2) and min(x1, x2) <= x <= max(x1, x2):
                cross = (x2 - x1) * (y - y1) - (y2 - y1) * (x - x1)
                if abs(cross) < 1e-6:
                    return True
            if (y1 > y) != (y2 > y):
                x_at = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
                if x < x_at:
                    inside = not inside
        return inside


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
