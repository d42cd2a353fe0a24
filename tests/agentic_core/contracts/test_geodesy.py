"""The one earth model: WGS-84 distances against an independent method (Vincenty's iteration) and published
values, the tangent plane against the distance, and every layer using this module rather than its own radius."""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agentic_core.contracts import geodesy
from agentic_core.contracts.geodesy import WGS84_A, WGS84_F, distance_m, local_offset, offset_position

ROOT = Path(geodesy.__file__).resolve().parents[2]


def vincenty_m(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Vincenty's inverse on WGS-84 (iterated on the auxiliary sphere), as an independent reference."""
    b = WGS84_A * (1 - WGS84_F)
    u1 = math.atan((1 - WGS84_F) * math.tan(math.radians(lat1)))
    u2 = math.atan((1 - WGS84_F) * math.tan(math.radians(lat2)))
    big_l = math.radians(lon2 - lon1)
    lam = big_l
    for _ in range(200):
        sin_l, cos_l = math.sin(lam), math.cos(lam)
        sin_s = math.hypot(math.cos(u2) * sin_l, math.cos(u1) * math.sin(u2) - math.sin(u1) * math.cos(u2) * cos_l)
        if sin_s == 0:
            return 0.0
        cos_s = math.sin(u1) * math.sin(u2) + math.cos(u1) * math.cos(u2) * cos_l
        sigma = math.atan2(sin_s, cos_s)
        sin_a = math.cos(u1) * math.cos(u2) * sin_l / sin_s
        cos2_a = 1 - sin_a**2
        cos_2sm = cos_s - 2 * math.sin(u1) * math.sin(u2) / cos2_a if cos2_a else 0.0
        c = WGS84_F / 16 * cos2_a * (4 + WGS84_F * (4 - 3 * cos2_a))
        previous = lam
        lam = big_l + (1 - c) * WGS84_F * sin_a * (sigma + c * sin_s * (cos_2sm + c * cos_s * (2 * cos_2sm**2 - 1)))
        if abs(lam - previous) < 1e-13:
            break
    u_sq = cos2_a * (WGS84_A**2 - b**2) / b**2
    big_a = 1 + u_sq / 16384 * (4096 + u_sq * (-768 + u_sq * (320 - 175 * u_sq)))
    big_b = u_sq / 1024 * (256 + u_sq * (-128 + u_sq * (74 - 47 * u_sq)))
    tail = big_b / 6 * cos_2sm * (4 * sin_s**2 - 3) * (4 * cos_2sm**2 - 3)
    d_sigma = big_b * sin_s * (cos_2sm + big_b / 4 * (cos_s * (2 * cos_2sm**2 - 1) - tail))
    return b * big_a * (sigma - d_sigma)


def test_published_values() -> None:
    assert distance_m(0.0, 0.0, 0.0, 1.0) == pytest.approx(111_319.491, abs=1e-3)  # a degree of the equator
    assert distance_m(0.0, 0.0, 1.0, 0.0) == pytest.approx(110_574.389, abs=1e-2)  # a degree of meridian at 0°
    assert distance_m(0.0, 0.0, 90.0, 0.0) == pytest.approx(10_001_965.729, abs=10.0)  # equator to pole
    assert distance_m(21.4225, 39.8262, 21.4225, 39.8262) == 0.0


mission_scale = st.tuples(st.floats(-80, 80), st.floats(-180, 180), st.floats(-0.05, 0.05), st.floats(-0.05, 0.05))


@settings(max_examples=300, deadline=None)
@given(mission_scale)
def test_within_five_centimetres_of_vincenty_over_a_mission(case: tuple[float, float, float, float]) -> None:
    lat, lon, dlat, dlon = case
    assert distance_m(lat, lon, lat + dlat, lon + dlon) == pytest.approx(
        vincenty_m(lat, lon, lat + dlat, lon + dlon), abs=0.05
    )


@settings(max_examples=300, deadline=None)
@given(st.floats(-89, 89), st.floats(-180, 180), st.floats(-89, 89), st.floats(-150, 150))
def test_within_five_parts_per_million_of_vincenty_across_continents(
    lat1: float, lon1: float, lat2: float, dlon: float
) -> None:
    reference = vincenty_m(lat1, lon1, lat2, lon1 + dlon)
    assert distance_m(lat1, lon1, lat2, lon1 + dlon) == pytest.approx(reference, rel=5e-6, abs=1e-6)


def test_symmetric_and_never_nan_even_at_the_antipode() -> None:
    for a, b in [((10.0, 20.0), (-10.0, -160.0)), ((0.0, 0.0), (0.0, 180.0)), ((90.0, 0.0), (-90.0, 0.0))]:
        there, back = distance_m(*a, *b), distance_m(*b, *a)
        assert there == pytest.approx(back) and math.isfinite(there)
        assert 19_900_000 < there < 20_100_000


@settings(max_examples=200, deadline=None)
@given(st.floats(-60, 60), st.floats(-180, 180), st.floats(-3000, 3000), st.floats(-3000, 3000))
def test_the_tangent_plane_agrees_with_the_distance(lat: float, lon: float, north: float, east: float) -> None:
    """Within 3 km up to 60° of latitude the plane's offsets and the ellipsoid's distance agree to one part in a
    thousand (as the module says), exactly along a meridian, and the plane's two directions invert each other."""
    there = offset_position(lat, lon, north, east)
    assert local_offset(lat, lon, *there) == pytest.approx((north, east), abs=1e-6)
    assert distance_m(lat, lon, *there) == pytest.approx(math.hypot(north, east), rel=1e-3, abs=0.05)
    assert distance_m(lat, lon, *offset_position(lat, lon, north, 0.0)) == pytest.approx(abs(north), abs=0.05)


def test_no_other_earth_radius_in_the_project() -> None:
    """A hostile look for a second earth model: no spherical radius or haversine anywhere but the contract."""
    pattern = re.compile(r"6_?37[01]_?0\d\d|haversine|EARTH_RADIUS", re.IGNORECASE)
    found = [
        f"{path.relative_to(ROOT)}:{n}"
        for top in ("agentic_core", "tools", "flight", "evaluation", "prompts")
        for path in (ROOT / top).rglob("*.py")
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert found == []
