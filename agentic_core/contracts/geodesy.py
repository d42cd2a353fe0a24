"""The one earth model: the WGS-84 ellipsoid, its local tangent plane (north/east metres from an origin and back)
and the distance between two latitude/longitude points.

Every layer that turns degrees into metres uses this module (the simulator's NED frame, the vehicle client, the
geofence, the mission validator and its ``distance_m``, perception, the incident log), so they all agree. The
tangent plane (equirectangular about the origin) is exact along the origin's meridian and parallel; elsewhere its
error grows with distance and latitude (under one part in a thousand within 3 km at latitudes up to 60°), well
within a mission's needs. :func:`distance_m` holds at any range.

>>> north, east = local_offset(21.4133, 39.8933, *offset_position(21.4133, 39.8933, 120.0, -75.0))
>>> round(north, 6), round(east, 6)
(120.0, -75.0)
>>> round(distance_m(0.0, 0.0, 0.0, 1.0), 2)  # one degree along the equator
111319.49
"""

from __future__ import annotations

import math

WGS84_A = 6378137.0
"""Semi-major axis (m)."""
WGS84_F = 1.0 / 298.257223563
"""Flattening."""
WGS84_E2 = 6.69437999014e-3
"""First eccentricity squared (f × (2 − f), as the simulator has always used it)."""
WGS84_MIN_RADIUS_M = WGS84_A * (1.0 - WGS84_E2)
"""The smallest radius of curvature anywhere on the ellipsoid (the meridian's, at the equator): a bounding box
drawn with it contains every point within a given distance."""


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


def distance_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Shortest distance (m) on the WGS-84 ellipsoid between two points (degrees), by Lambert's formula.

    Lambert corrects the great circle between the points' reduced latitudes for the flattening: within 5 parts
    per million of the exact geodesic (a few centimetres over a mission's kilometres, far below GPS noise; tens of
    metres across half the globe). For two points
    almost exactly opposite each other (where the formula has no limit) it falls back to the arc on a sphere of
    radius :data:`WGS84_A`.
    """
    b1 = math.atan((1.0 - WGS84_F) * math.tan(math.radians(lat1)))
    b2 = math.atan((1.0 - WGS84_F) * math.tan(math.radians(lat2)))
    dlon = math.radians(lon2 - lon1)
    h = math.sin((b2 - b1) / 2) ** 2 + math.cos(b1) * math.cos(b2) * math.sin(dlon / 2) ** 2
    sigma = 2.0 * math.asin(min(1.0, math.sqrt(h)))
    half_sin2, half_cos2 = math.sin(sigma / 2) ** 2, math.cos(sigma / 2) ** 2
    if half_sin2 < 1e-30 or half_cos2 < 1e-12:
        return WGS84_A * sigma
    p, q = (b1 + b2) / 2, (b2 - b1) / 2
    x = (sigma - math.sin(sigma)) * math.sin(p) ** 2 * math.cos(q) ** 2 / half_cos2
    y = (sigma + math.sin(sigma)) * math.cos(p) ** 2 * math.sin(q) ** 2 / half_sin2
    return WGS84_A * (sigma - WGS84_F / 2.0 * (x + y))


__all__ = [
    "WGS84_A",
    "WGS84_E2",
    "WGS84_F",
    "WGS84_MIN_RADIUS_M",
    "distance_m",
    "earth_radii",
    "geodetic_to_ned",
    "local_offset",
    "ned_to_geodetic",
    "offset_position",
]
