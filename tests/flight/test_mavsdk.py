"""The official MAVSDK flies the simulated vehicle as it would fly PX4 SITL: connect, health, arm, take off, go to,
offboard, land.

Why: the architecture promises that any MAVLink client can fly the simulated F450 with its default settings. MAVSDK
is the strictest of them (it checks health bits, the parameter encoding, command ACKs and mode numbers), so this
is the conformance test of :mod:`flight.mavlink` against a real, independent implementation of the other side.

The ``mavsdk`` package from version 4 is the native binding: it loads the C++ library (``libcmavsdk.so``, bundled
in the wheel) through ``ctypes``; no ``mavsdk_server`` process runs. The test uses its asyncio API, as MAVSDK's
examples do. MAVSDK listens, the vehicle sends to it, as with PX4 SITL and MAVSDK's default ``udpin://0.0.0.0:14540``:
here on a free port and on 127.0.0.1 only, so that parallel runs do not collide and nothing leaves the machine.
The vehicle runs free on its own thread at :data:`SPEED` × real time; MAVSDK's timeouts and 20 Hz setpoint stream
are on the wall clock, which the vehicle's link and offboard timeouts follow while it runs free.

Every wait is bounded (:func:`until`) and asserts the state reached, not how long it took.
"""

from __future__ import annotations

import asyncio
import math
import socket
from collections.abc import Awaitable, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypeVar

import pytest

pytest.importorskip(
    "mavsdk.asyncio", reason="the mavsdk package (>= 4, the native binding; dev extra) is not importable"
)

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync, ActionError
from mavsdk.asyncio.plugins.info import InfoAsync
from mavsdk.asyncio.plugins.offboard import OffboardAsync, PositionNedYaw, VelocityNedYaw
from mavsdk.asyncio.plugins.param import ParamAsync
from mavsdk.asyncio.plugins.telemetry import FixType, FlightMode, LandedState, TelemetryAsync

from agentic_core.contracts.geodesy import local_offset, offset_position
from flight.mavlink import PARAMS, MavlinkVehicle
from flight.sim import Environment, Simulator
from flight.sim.environment import GpsNoiseSettings

SPEED = 50.0
"""Simulated seconds per wall second while MAVSDK flies (as the other free-running flight tests)."""
WAIT_S = 20.0
"""The longest any single wait may take (wall seconds); a safety net, never reached when things work."""
TEST_TIMEOUT_S = 45.0

T = TypeVar("T")


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Drone:
    """One MAVSDK instance connected to the vehicle, with the plugins a script would create."""

    def __init__(self, mavsdk: Mavsdk, system: Any) -> None:
        self.mavsdk = mavsdk
        self.system = system
        self.action = ActionAsync(system)
        self.telemetry = TelemetryAsync(system)
        self.offboard = OffboardAsync(system)
        self.param = ParamAsync(system)
        self.info = InfoAsync(system)


async def until(read: Callable[[], Awaitable[T]], done: Callable[[T], bool], timeout_s: float = WAIT_S) -> T:
    """Poll ``read`` until ``done(value)``; returns the last value (the caller asserts on it)."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout_s
    value = await read()
    while not done(value) and loop.time() < end:
        await asyncio.sleep(0.02)
        value = await read()
    return value


async def connect(port: int) -> Drone:
    """MAVSDK as a ground station listening on ``port``, waiting for the autopilot to appear."""
    mavsdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
    await mavsdk.add_any_connection(f"udpin://127.0.0.1:{port}")
    system = await mavsdk.first_autopilot(timeout_s=WAIT_S)
    if system is None:
        mavsdk.destroy()
        pytest.fail("MAVSDK did not discover the vehicle")
    return Drone(mavsdk, system)


@dataclass
class Sitl:
    """The vehicle running free on its thread and the UDP port it sends to (where MAVSDK listens)."""

    vehicle: MavlinkVehicle
    port: int

    def fly(self, script: Callable[[Drone], Awaitable[None]]) -> None:
        """Run ``script`` with a fresh MAVSDK connected to the vehicle, bounded by :data:`TEST_TIMEOUT_S`."""

        async def main() -> None:
            drone = await connect(self.port)
            try:
                await script(drone)
            finally:
                drone.mavsdk.destroy()

        asyncio.run(asyncio.wait_for(main(), TEST_TIMEOUT_S))


@contextmanager
def running(simulator: Simulator) -> Iterator[Sitl]:
    """The vehicle at :data:`SPEED`, sending to a free port as PX4 SITL sends to MAVSDK's 14540; closed after."""
    port = free_port()
    vehicle = MavlinkVehicle(simulator, gcs=None, api=("127.0.0.1", port))
    try:
        vehicle.start(speed=SPEED)
        yield Sitl(vehicle, port)
    finally:
        vehicle.close()


@pytest.fixture
def sitl() -> Iterator[Sitl]:
    with running(Simulator(seed=7)) as s:
        yield s


def horizontal_error_m(lat0: float, lon0: float, lat: float, lon: float) -> float:
    north, east = local_offset(lat0, lon0, lat, lon)
    return math.hypot(north, east)


# -- connection and health ------------------------------------------------------------------------------------------


def test_mavsdk_connects_and_finds_a_healthy_px4_quadrotor(sitl):
    home = sitl.vehicle.sim.environment.home

    async def script(drone: Drone) -> None:
        assert await drone.system.is_connected()
        assert (await drone.system.autopilot_type()).name == "PX4"
        assert (await drone.system.vehicle_type()).name == "MULTICOPTER"
        health = await until(
            drone.telemetry.health, lambda h: h.is_global_position_ok and h.is_home_position_ok and h.is_armable
        )
        assert health.is_global_position_ok and health.is_home_position_ok and health.is_local_position_ok
        assert health.is_armable  # SYS_STATUS pre-arm bit
        assert await drone.telemetry.health_all_ok()
        gps = await drone.telemetry.gps_info()
        assert gps.num_satellites >= 6 and gps.fix_type == FixType.FIX_3D
        tel_home = await until(drone.telemetry.home, lambda h: h.absolute_altitude_m > 0)
        assert abs(tel_home.latitude_deg - home.lat_deg) < 1e-6 and abs(tel_home.longitude_deg - home.lon_deg) < 1e-6
        assert abs(tel_home.absolute_altitude_m - home.alt_msl_m) < 0.01
        version = await drone.info.get_version()
        assert (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch) == (1, 14, 0)
        assert not await drone.telemetry.armed() and not await drone.telemetry.in_air()
        assert await drone.telemetry.landed_state() == LandedState.ON_GROUND

    sitl.fly(script)


def test_mavsdk_sees_why_it_cannot_arm_without_enough_satellites():
    environment = Environment(gps=GpsNoiseSettings(satellites=4))
    with running(Simulator(environment, seed=7)) as sitl:

        async def script(drone: Drone) -> None:
            health = await until(drone.telemetry.health, lambda h: h.is_home_position_ok)
            assert health.is_home_position_ok and not health.is_armable
            with pytest.raises(ActionError) as refused:
                await drone.action.arm()
            assert refused.value.result.name in ("COMMAND_DENIED", "TEMPORARILY_REJECTED")
            assert not await drone.telemetry.armed()

        sitl.fly(script)
        assert not sitl.vehicle.sim.armed
        assert any("no 3D GPS fix" in text for _, text in sitl.vehicle.statustexts)


def test_mavsdk_reads_and_writes_px4_parameters(sitl):
    async def script(drone: Drone) -> None:
        every = await drone.param.get_all_params()
        names = {p.name for p in every.int_params} | {p.name for p in every.float_params}
        assert names == {p.name for p in PARAMS}
        assert await drone.param.get_param_int("COM_DL_LOSS_T") == 10  # INT32, bytewise on the wire
        await drone.param.set_param_int("COM_DL_LOSS_T", 20)
        assert await drone.param.get_param_int("COM_DL_LOSS_T") == 20
        await drone.action.set_return_to_launch_altitude(40.0)  # RTL_RETURN_ALT, REAL32
        assert await drone.action.get_return_to_launch_altitude() == pytest.approx(40.0)
        await drone.action.set_takeoff_altitude(12.5)  # MIS_TAKEOFF_ALT
        assert await drone.action.get_takeoff_altitude() == pytest.approx(12.5)

    sitl.fly(script)
    params = sitl.vehicle.params
    assert (params["COM_DL_LOSS_T"], params["RTL_RETURN_ALT"], params["MIS_TAKEOFF_ALT"]) == (20, 40.0, 12.5)


# -- a whole flight -------------------------------------------------------------------------------------------------


async def take_off(drone: Drone, altitude_m: float) -> None:
    await drone.action.set_takeoff_altitude(altitude_m)
    await drone.action.arm()
    assert await until(drone.telemetry.armed, bool)
    await drone.action.takeoff()
    # PX4: Takeoff switches to Hold once the altitude is reached.
    mode = await until(drone.telemetry.flight_mode, lambda m: m == FlightMode.HOLD)
    assert mode == FlightMode.HOLD
    position = await until(drone.telemetry.position, lambda p: abs(p.relative_altitude_m - altitude_m) < 0.3)
    assert abs(position.relative_altitude_m - altitude_m) < 0.3
    assert await drone.telemetry.in_air()
    # EXTENDED_SYS_STATE comes at 1 Hz (simulated): the landed state may lag the mode by one message.
    assert await until(drone.telemetry.landed_state, lambda s: s == LandedState.IN_AIR) == LandedState.IN_AIR


async def go_to(drone: Drone, lat: float, lon: float, alt_msl: float, yaw_deg: float) -> None:
    await drone.action.goto_location(lat, lon, alt_msl, yaw_deg)

    def arrived(p: Any) -> bool:
        return (
            horizontal_error_m(lat, lon, p.latitude_deg, p.longitude_deg) < 0.5
            and abs(p.absolute_altitude_m - alt_msl) < 0.3
        )

    position = await until(drone.telemetry.position, arrived)
    assert horizontal_error_m(lat, lon, position.latitude_deg, position.longitude_deg) < 0.5
    assert abs(position.absolute_altitude_m - alt_msl) < 0.3
    heading = await until(drone.telemetry.heading, lambda h: abs((h.heading_deg - yaw_deg + 180) % 360 - 180) < 3)
    assert abs((heading.heading_deg - yaw_deg + 180) % 360 - 180) < 3
    assert await drone.telemetry.flight_mode() == FlightMode.HOLD


async def offboard_velocity_then_position(drone: Drone) -> None:
    # Offboard needs a setpoint before it starts; MAVSDK then streams it at 20 Hz.
    await drone.offboard.set_velocity_ned(VelocityNedYaw(0.0, -2.0, 0.0, 270.0))
    await drone.offboard.start()
    assert await drone.offboard.is_active()
    assert await until(drone.telemetry.flight_mode, lambda m: m == FlightMode.OFFBOARD) == FlightMode.OFFBOARD

    def at_speed(v: Any) -> bool:
        return bool(abs(v.east_m_s + 2.0) < 0.1 and abs(v.north_m_s) < 0.1 and abs(v.down_m_s) < 0.1)

    velocity = await until(drone.telemetry.velocity_ned, at_speed)
    assert abs(velocity.east_m_s + 2.0) < 0.1 and abs(velocity.north_m_s) < 0.1 and abs(velocity.down_m_s) < 0.1

    target = (-10.0, 15.0, -12.0)  # NED from home, as LOCAL_POSITION_NED reports it
    await drone.offboard.set_position_ned(PositionNedYaw(*target, 180.0))

    def at_target(pv: Any) -> bool:
        p = pv.position
        return math.dist((p.north_m, p.east_m, p.down_m), target) < 0.3

    pv = await until(drone.telemetry.position_velocity_ned, at_target)
    assert math.dist((pv.position.north_m, pv.position.east_m, pv.position.down_m), target) < 0.3
    attitude = await until(drone.telemetry.attitude_euler, lambda a: abs(abs(a.yaw_deg) - 180.0) < 3.0)
    assert abs(abs(attitude.yaw_deg) - 180.0) < 3.0
    assert await drone.telemetry.flight_mode() == FlightMode.OFFBOARD  # the 20 Hz wall-clock stream keeps it

    await drone.offboard.stop()  # PX4 (and MAVSDK's docs): back to Hold
    assert await until(drone.telemetry.flight_mode, lambda m: m == FlightMode.HOLD) == FlightMode.HOLD
    assert not await drone.offboard.is_active()


async def land(drone: Drone) -> None:
    start = await drone.telemetry.position()
    await drone.action.land()
    assert await until(drone.telemetry.armed, lambda armed: not armed) is False  # PX4 disarms on touchdown
    assert await until(drone.telemetry.in_air, lambda flying: not flying) is False
    assert await until(drone.telemetry.landed_state, lambda s: s == LandedState.ON_GROUND) == LandedState.ON_GROUND
    end = await drone.telemetry.position()
    assert abs(end.relative_altitude_m) < 0.3
    assert horizontal_error_m(start.latitude_deg, start.longitude_deg, end.latitude_deg, end.longitude_deg) < 1.0


def test_mavsdk_flies_takeoff_goto_offboard_and_land(sitl):
    vehicle = sitl.vehicle
    home = vehicle.sim.environment.home

    async def script(drone: Drone) -> None:
        await until(drone.telemetry.health, lambda h: h.is_armable and h.is_global_position_ok)
        await take_off(drone, 10.0)
        lat, lon = offset_position(home.lat_deg, home.lon_deg, 30.0, 20.0)
        await go_to(drone, lat, lon, home.alt_msl_m + 15.0, 90.0)
        await offboard_velocity_then_position(drone)
        await land(drone)

    sitl.fly(script)
    s = vehicle.sim.state()
    assert not s.armed and s.landed
    assert abs(s.north_m + 10.0) < 1.0 and abs(s.east_m - 15.0) < 1.0  # landed under the last offboard target
    assert vehicle.failsafes.triggered == []  # no link loss, geofence or battery event on the way
