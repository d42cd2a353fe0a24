"""Positions on a local tangent plane of the WGS-84 ellipsoid: north/east/down metres from a home point and back.

Shared by the simulator (its NED frame) and the agent's MAVLink client (offsets between fixes). Good to
centimetres over a few kilometres, which is the scale of a mission.

>>> north, east = local_offset(21.4133, 39.8933, *offset_position(21.4133, 39.8933, 120.0, -75.0))
>>> round(north, 6), round(east, 6)
(120.0, -75.0)
"""

from __future__ import annotations

import math

WGS84_A = 6378137.0
"""Semi-major axis (m)."""
WGS84_E2 = 6.69437999014e-3
"""First eccentricity squared."""


def earth_radii(lat_deg: float) -> tuple[float, float]:
    """Meridian and prime-vertical radii of curvature (m) of the WGS-84 ellipsoid at a geodetic latitude."""
    s = math.sin(math.radians(lat_deg))
    w = math.sqrt(1.0 - WGS84_E2 * s * s)
    r_meridian = WGS84_A * (1.0 - WGS84_E2) / (w * w * w)
    r_normal = WGS84_A / w
    return r_meridian, r_normal


def local_offset(lat0: float, lon0: float, lat: float, lon: float) -> tuple[float, float]:
    """(north, east) metres of ``lat, lon`` from ``lat0, lon0``, on the tangent plane at ``lat0``."""
    r_m, r_n = earth_radii(lat0)
    return math.radians(lat - lat0) * r_m, math.radians(lon - lon0) * r_n * math.cos(math.radians(lat0))


def offset_position(lat0: float, lon0: float, north_m: float, east_m: float) -> tuple[float, float]:
    """The latitude and longitude ``north_m``/``east_m`` from ``lat0, lon0`` (the inverse of :func:`local_offset`)."""
    r_m, r_n = earth_radii(lat0)
    return lat0 + math.degrees(north_m / r_m), lon0 + math.degrees(east_m / (r_n * math.cos(math.radians(lat0))))


def geodetic_to_ned(
    lat_deg: float, lon_deg: float, alt_m: float, home_lat_deg: float, home_lon_deg: float, home_alt_m: float
) -> tuple[float, float, float]:
    """North, east, down (m) of a point from home, on the tangent plane at home."""
    north, east = local_offset(home_lat_deg, home_lon_deg, lat_deg, lon_deg)
    return north, east, home_alt_m - alt_m


def ned_to_geodetic(
    north: float, east: float, down: float, home_lat_deg: float, home_lon_deg: float, home_alt_m: float
) -> tuple[float, float, float]:
    """Inverse of :func:`geodetic_to_ned`: latitude, longitude (degrees) and altitude (m)."""
    lat, lon = offset_position(home_lat_deg, home_lon_deg, north, east)
    return lat, lon, home_alt_m - down
