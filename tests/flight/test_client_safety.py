"""The client's safety set-up end to end against the simulated vehicle on a thread: the fence and altitude limits
uploaded, read back and then enforced by the vehicle; bad fences refused before anything is sent; failures
injected through the client."""

import math
from typing import Any

import pytest
from pymavlink import mavutil

from flight.geodesy import offset_position
from flight.mavlink import FlightMode
from flight.mavlink.geofence import Circle, Polygon
from flight.vehicle import VehicleClient
from tests.waiting import CONNECT_S

from .test_client import run

m = mavutil.mavlink


def at(vehicle, north, east):
    home = vehicle.sim.environment.home
    return offset_position(home.lat_deg, home.lon_deg, north, east)


def test_a_polygon_fence_is_uploaded_read_back_and_is_what_the_failsafe_checks(vehicle):
    square = [at(vehicle, n, e) for n, e in ((-50, -50), (50, -50), (50, 50), (-50, 50))]

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            result: Any = await client.upload_fence(polygon=square, max_alt_m=25.0, floor_m=3.0)
            assert result.ok, result
            assert result.items == 4
            assert result.params == {"GF_MAX_VER_DIST": 25.0, "RTL_RETURN_ALT": 24.0, "GF_MIN_ALT": 3.0}
            # what the vehicle enforces is what was sent, in metres from home
            (area,) = vehicle.navigator.fence.areas
            assert isinstance(area, Polygon) and area.inclusion
            corners = sorted((round(n), round(e)) for n, e in area.vertices)
            assert corners == [(-50, -50), (-50, 50), (50, -50), (50, 50)]
            fence = vehicle.navigator.fence
            assert fence.violation(49.0, 0.0, 10.0) is None
            assert fence.violation(51.0, 0.0, 10.0) is not None and fence.violation(0.0, 0.0, 26.0) is not None
            # and the vehicle refuses a target outside it, and one under the floor
            assert (await client.arm()).ok
            assert (await client.takeoff(8.0)).ok
            lat, lon = at(vehicle, 80, 0)
            outside = await client.goto(lat, lon, 8.0)
            assert outside.status == "denied" and "inclusion fence" in (outside.reason or "")
            lat, lon = at(vehicle, 10, 0)
            low = await client.goto(lat, lon, 2.0)
            assert low.status == "denied" and "floor" in (low.reason or "")

    run(go(), 60.0)


def test_a_circle_fence_caps_a_high_return_altitude(vehicle):
    centre = at(vehicle, 0, 0)

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert await client.set_param("RTL_RETURN_ALT", 80.0) == 80.0
            result: Any = await client.upload_fence(circle=(*centre, 150.0), max_alt_m=40.0)
            assert result.ok and result.items == 1, result
            assert result.params["RTL_RETURN_ALT"] == 39.0 and result.params["GF_MAX_VER_DIST"] == 40.0
            assert "GF_MIN_ALT" not in result.params  # not asked for: left alone
            (area,) = vehicle.navigator.fence.areas
            assert isinstance(area, Circle) and area.radius_m == pytest.approx(150.0)
            # a lower existing RTL_RETURN_ALT is kept
            assert await client.set_param("RTL_RETURN_ALT", 15.0) == 15.0
            again: Any = await client.upload_fence(circle=(*centre, 150.0), max_alt_m=40.0)
            assert again.ok and again.params["RTL_RETURN_ALT"] == 15.0

    run(go(), 60.0)


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"polygon": [(21.4, 39.8), (21.5, 39.8)], "max_alt_m": 25.0}, "at least 3 vertices"),
        ({"polygon": [(91.0, 0.0), (0.0, 0.0), (0.0, 1.0)], "max_alt_m": 25.0}, "vertex 0"),
        ({"circle": (21.4, 39.8, -5.0), "max_alt_m": 25.0}, "radius"),
        ({"circle": (21.4, 39.8, math.nan), "max_alt_m": 25.0}, "radius"),
        ({"circle": (21.4, 39.8, 100.0), "polygon": [(0, 0), (0, 1), (1, 1)], "max_alt_m": 25.0}, "not both"),
        ({"circle": (21.4, 39.8, 100.0), "max_alt_m": math.inf}, "max_alt_m"),
        ({"circle": (21.4, 39.8, 100.0), "max_alt_m": 25.0, "floor_m": 30.0}, "floor_m"),
        ({"circle": (21.4, 39.8, 100.0), "max_alt_m": 25.0, "floor_m": -1.0}, "floor_m"),
    ],
)
def test_a_bad_fence_fails_with_a_reason_and_sends_nothing(vehicle, kwargs, words):
    before = vehicle.params["GF_MAX_VER_DIST"]

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            return await client.upload_fence(**kwargs)

    result: Any = run(go(), 30.0)
    assert result.status == "failed" and words in (result.reason or ""), result
    assert vehicle.navigator.fence.areas == () and vehicle.params["GF_MAX_VER_DIST"] == before


def test_a_fence_the_vehicle_refuses_is_reported_denied(vehicle):
    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            # a ceiling above what the vehicle accepts (GF_MAX_VER_DIST is at most 10000 m)
            return await client.upload_fence(circle=(*at(vehicle, 0, 0), 100.0), max_alt_m=20000.0)

    result: Any = run(go(), 30.0)
    assert result.status == "denied" and "GF_MAX_VER_DIST" in (result.reason or ""), result


def test_inject_failure_through_the_client(vehicle):
    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            refused = await client.inject_failure(m.FAILURE_UNIT_SYSTEM_BATTERY, m.FAILURE_TYPE_OFF)
            assert refused.status == "denied" and "SYS_FAILURE_EN" in (refused.reason or "")
            assert await client.set_param("SYS_FAILURE_EN", 1) == 1
            unsupported = await client.inject_failure(m.FAILURE_UNIT_SENSOR_GYRO, m.FAILURE_TYPE_OFF)
            assert unsupported.status == "unsupported"
            assert (await client.arm()).ok
            assert (await client.takeoff(6.0)).ok
            low = await client.inject_failure(m.FAILURE_UNIT_SYSTEM_BATTERY, m.FAILURE_TYPE_SLOW)
            assert low.ok
            returning = await client._wait(lambda _msg: True if client._state.mode == "rtl" else None, 10.0)
            assert returning and vehicle.mode is FlightMode.RTL

    run(go(), 60.0)
