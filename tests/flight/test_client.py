"""The agent's MAVLink client (flight.vehicle) flying the simulated vehicle over UDP, which runs on a thread."""

import asyncio
import math
import socket
from typing import Any

import pytest
from pymavlink.dialects.v20.common import MAV_RESULT_UNSUPPORTED

from agentic_core.contracts.geodesy import local_offset, offset_position
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from flight.vehicle import VehicleClient, VehicleConnectionError, parse_address
from tests.waiting import CONNECT_S, wait_for_async

from .conftest import FAST_FORWARD


def free_udp_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def run(coro, timeout_s=30.0):
    """Run a coroutine on a fresh loop, bounded: a hang fails the test instead of stalling the suite."""

    async def bounded():
        return await asyncio.wait_for(coro, timeout_s)

    return asyncio.run(bounded())


def horizontal(telemetry, lat, lon):
    north, east = local_offset(lat, lon, telemetry.lat_deg, telemetry.lon_deg)
    return math.hypot(north, east)


def test_local_offsets_round_trip_and_addresses_parse():
    lat, lon = offset_position(21.4133, 39.8933, 120.0, -75.0)
    north, east = local_offset(21.4133, 39.8933, lat, lon)
    assert abs(north - 120.0) < 1e-6 and abs(east + 75.0) < 1e-6
    assert abs((lat - 21.4133) * 110_760 - 120.0) < 1.0  # a degree of latitude is about 110.8 km at 21° N
    assert parse_address("127.0.0.1:14550") == (("127.0.0.1", 14550), False)
    assert parse_address("udpin:0.0.0.0:14540") == (("0.0.0.0", 14540), True)
    assert parse_address(("localhost", 5)) == (("localhost", 5), False)
    with pytest.raises(ValueError):
        parse_address("nowhere")


def test_arm_takeoff_goto_land(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert client.telemetry.connected and client.telemetry.mode == "hold"
            assert not client.telemetry.armed
            updates = []
            sub = client.subscribe()

            async def watch():
                async for t in sub:
                    updates.append(t)

            watcher = asyncio.create_task(watch())

            armed: Any = await client.arm()
            assert armed.status == "ok" and armed.reached and armed.state.armed

            up: Any = await client.takeoff(10.0)
            assert up.status == "ok" and up.reached, up.reason
            assert abs(up.state.alt_m - 10.0) < 0.6
            assert up.state.landed_state in ("in_air", "takeoff")

            home: Any = client.home
            assert home is not None and abs(home[0] - 21.4133) < 1e-6 and abs(home[2] - 300.0) < 0.01
            lat, lon = offset_position(home[0], home[1], 40.0, -25.0)
            there: Any = await client.goto(lat, lon, 15.0)
            assert there.status == "ok" and there.reached, there.reason
            assert horizontal(there.state, lat, lon) < 1.5
            assert abs(there.state.alt_m - 15.0) < 1.0
            # LOCAL_POSITION_NED comes apart from GLOBAL_POSITION_INT, up to a stream period older: more slack
            assert abs(there.state.north_m - 40.0) < 3.0 and abs(there.state.east_m + 25.0) < 3.0
            truth = vehicle.sim.state()
            assert math.hypot(truth.north_m - 40.0, truth.east_m + 25.0) < 2.0

            local: Any = await client.goto_local(10.0, 10.0)  # altitude kept
            ten_ten = offset_position(home[0], home[1], 10.0, 10.0)
            assert local.status == "ok" and horizontal(local.state, *ten_ten) < 1.5
            assert abs(local.state.alt_m - 15.0) < 1.0

            down: Any = await client.land()
            assert down.status == "ok" and down.reached, down.reason
            assert not down.state.armed and abs(down.state.alt_m) < 0.3
            assert abs(down.state.north_m - 10.0) < 2.0 and abs(down.state.east_m - 10.0) < 2.0
            assert down.state.mode == "land"

            sub.close()
            await asyncio.wait_for(watcher, 2.0)
            assert len(updates) > 10 and any(u.armed for u in updates)

    run(fly())


def test_orbit_is_flown_as_waypoints_when_do_orbit_is_unsupported_then_hover_and_payload(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert (await client.arm()).ok
            assert (await client.takeoff(8.0)).ok
            result, _ = await client.command(34, (10.0,), frame=6, x=0, y=0, z=math.nan, attempts=1, timeout_s=5.0)
            assert result == MAV_RESULT_UNSUPPORTED  # the simulated vehicle has no DO_ORBIT
            home: Any = client.home
            distances = []
            sub = client.subscribe()

            async def watch():
                async for t in sub:
                    distances.append(horizontal(t, home[0], home[1]))

            watcher = asyncio.create_task(watch())
            circle: Any = await client.orbit(home[0], home[1], 12.0, turns=1.0, alt_m=10.0)
            sub.close()
            await asyncio.wait_for(watcher, 2.0)
            assert circle.status == "ok" and circle.reached, circle.reason
            assert "waypoints" in circle.reason and circle.action == "orbit"
            assert abs(horizontal(circle.state, home[0], home[1]) - 12.0) < 3.0
            assert abs(circle.state.alt_m - 10.0) < 2.0
            last_leg = distances[len(distances) // 3 :]  # once on the circle, it stays near it
            assert min(last_leg) > 8.0 and max(last_leg) < 15.0

            t0 = client.telemetry.time_boot_s
            hovered: Any = await client.hover(4.0)
            assert hovered.status == "ok" and hovered.state.mode == "hold"
            assert hovered.state.time_boot_s - t0 >= 4.0
            assert (await client.deploy_payload()).ok
            assert vehicle.sim.payload_released

            home_again: Any = await client.rtl()
            assert home_again.status == "ok" and home_again.reached, home_again.reason
            assert horizontal(home_again.state, home[0], home[1]) < 5.0 and not home_again.state.armed

    run(fly(), timeout_s=45.0)


def test_refusals_are_denied_with_the_vehicles_reason(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            early: Any = await client.takeoff(10.0)
            assert early.status == "denied" and "arm first" in early.reason
            assert early.ack == 2 and early.reached is None

            assert await client.set_param("GF_MAX_HOR_DIST", 50.0) == 50.0
            assert await client.get_param("GF_MAX_HOR_DIST") == 50.0
            assert await client.set_param("COM_DL_LOSS_T", 60) == 60.0  # an INT32, bytewise on the wire
            assert (await client.arm()).ok
            assert (await client.takeoff(5.0)).ok
            far: Any = await client.goto_local(200.0, 0.0, 10.0)
            assert far.status == "denied", far
            assert "fence" in far.reason.lower() and "200" in far.reason
            assert far.reached is False or far.reached is None
            assert far.state.armed and abs(far.state.alt_m - 5.0) < 1.0  # still holding where it was

            near: Any = await client.goto_local(20.0, 0.0)
            assert near.status == "ok"

    run(fly())


def test_a_stopped_vehicle_times_out_and_connect_gives_up(vehicle):
    async def fly():
        client = await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S, ack_timeout_s=0.2, ack_attempts=2)
        try:
            vehicle.stop()  # the socket stays open, nothing answers
            result: Any = await client.arm()
            assert result.status == "timeout" and result.ack is None
            assert "no COMMAND_ACK" in result.reason
            assert result.elapsed_s < 2.0
            await asyncio.sleep(0)
        finally:
            client.close()
        assert client.closed
        with pytest.raises(VehicleConnectionError):
            await VehicleClient.connect(("127.0.0.1", free_udp_port()), timeout_s=0.3)

    run(fly())


def test_a_vehicle_that_stops_mid_flight_makes_the_wait_time_out(vehicle):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert (await client.arm()).ok
            assert (await client.takeoff(5.0)).ok
            home: Any = client.home
            lat, lon = offset_position(home[0], home[1], 200.0, 0.0)
            task = asyncio.create_task(client.goto(lat, lon, timeout_s=1.0))
            await wait_for_async(  # the vehicle took the goto (200 m north) before it stops
                lambda: getattr(vehicle.sim.controller.setpoint, "north_m", 0.0) > 100.0, 5, what="the goto setpoint"
            )
            vehicle.stop()
            result: Any = await task
            assert result.status == "timeout" and result.reached is False
            assert "not reached in 1 s" in result.reason

    run(fly())


def test_listening_client_hears_a_vehicle_that_sends_to_it():
    port = free_udp_port()
    v = MavlinkVehicle(Simulator(seed=1), gcs=None, api=("127.0.0.1", port))
    v.start(speed=FAST_FORWARD)
    try:

        async def listen():
            async with await VehicleClient.connect(f"udpin:127.0.0.1:{port}", timeout_s=CONNECT_S) as client:
                assert client.remote == v.address
                assert (await client.arm()).ok  # answers go back to where the vehicle sends from

        run(listen())
    finally:
        v.close()


def test_deadlines_run_on_the_vehicles_clock_so_a_slow_simulation_is_not_a_timeout():
    """At 0.4 times real time, a 20 m leg (about 5 s of the vehicle's time, 12 s of wall time) fits an 8 s budget
    of the vehicle's time, not of wall time: it arrives. A budget too small in the vehicle's time still times
    out."""
    slow = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None)
    slow.start(speed=FAST_FORWARD)

    async def fly():
        async with await VehicleClient.connect(slow.address, timeout_s=CONNECT_S) as client:
            assert (await client.arm()).ok
            assert (await client.takeoff(5.0)).ok
            slow.stop()
            slow.start(speed=0.4)
            home: Any = client.home
            lat, lon = offset_position(home[0], home[1], 20.0, 0.0)
            t0 = asyncio.get_running_loop().time()
            arrived: Any = await client.goto(lat, lon, speed_mps=5.0, timeout_s=8.0)
            wall = asyncio.get_running_loop().time() - t0
            assert arrived.status == "ok", arrived.reason
            assert wall > 8.0  # more wall time than the budget: the wall clock alone would have given up
            lat, lon = offset_position(home[0], home[1], 60.0, 0.0)
            short: Any = await client.goto(lat, lon, speed_mps=5.0, timeout_s=1.0)
            assert short.status == "timeout" and "not reached in 1 s" in short.reason

    try:
        run(fly(), timeout_s=60.0)
    finally:
        slow.close()
