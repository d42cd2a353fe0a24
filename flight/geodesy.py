"""The WGS-84 tangent plane, re-exported from :mod:`agentic_core.contracts.geodesy` (the project's one earth model)
for the flight modules that import it from here.

>>> from agentic_core.contracts import geodesy
>>> local_offset is geodesy.local_offset
True
"""

from __future__ import annotations

from agentic_core.contracts.geodesy import (
    WGS84_A,
    WGS84_E2,
    earth_radii,
    geodetic_to_ned,
    local_offset,
    ned_to_geodetic,
    offset_position,
)

__all__ = [
    "WGS84_A",
    "WGS84_E2",
    "earth_radii",
    "geodetic_to_ned",
    "local_offset",
    "ned_to_geodetic",
    "offset_position",
]
