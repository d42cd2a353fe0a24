"""A swarm's search area split into sectors, one per UAV: the area's bounding box cut into equal strips from south
to north, each a rectangle of latitude and longitude with its centre in the swarm's local frame (metres from home).
A survey's lines run east-west (:func:`agentic_core.mission.geometry.lawnmower`), so a strip as deep as the
survey's spacing is one line, its whole width long.

>>> area = [(21.4120, 39.8920), (21.4140, 39.8920), (21.4140, 39.8940), (21.4120, 39.8940)]
>>> sectors = split(area, 2, home=(21.4130, 39.8930))
>>> [s.id for s in sectors], [round(s.centre.north) for s in sectors]
(['S1', 'S2'], [-55, 55])
>>> len(sectors[0].polygon)
4
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import local_offset
from agentic_core.contracts.swarm import Point


@dataclass(frozen=True)
class Sector:
    """One UAV's share of the area: a lat/lon rectangle (corners in order) and its centre (local metres)."""

    id: str
    polygon: tuple[tuple[float, float], ...]
    centre: Point

    def corners(self) -> list[dict[str, float]]:
        """The corners as a survey step's polygon takes them."""
        return [{"lat": lat, "lon": lon} for lat, lon in self.polygon]


def split(area: Sequence[tuple[float, float]], n: int, *, home: tuple[float, float]) -> list[Sector]:
    """``n`` strips of ``area``'s bounding box (lat, lon corners), south to north, centres relative to ``home``."""
    if n < 1:
        raise InputError(f"cannot split an area into {n} sectors")
    if len(area) < 3:
        raise InputError("a swarm's area needs at least 3 corners")
    south, north = min(p[0] for p in area), max(p[0] for p in area)
    west, east = min(p[1] for p in area), max(p[1] for p in area)
    if north <= south or east <= west:
        raise InputError("a swarm's area has no extent")
    depth = (north - south) / n
    sectors = []
    for i in range(n):
        s, n_ = south + i * depth, south + (i + 1) * depth
        centre_n, centre_e = local_offset(home[0], home[1], (s + n_) / 2, (west + east) / 2)
        polygon = ((s, west), (n_, west), (n_, east), (s, east))
        sectors.append(Sector(f"S{i + 1}", polygon, Point(north=centre_n, east=centre_e)))
    return sectors


__all__ = ["Sector", "split"]
