"""Attacks on the agent's client, and the signed client flying a signed vehicle: a spoofer on another socket
cannot make ``goto`` report a position the vehicle is not at; the client refuses what the vehicle did not sign."""

import asyncio

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from agentic_core.contracts.geodesy import local_offset, offset_position
from flight.mavlink import MavlinkVehicle
from flight.signing import new_key
from flight.sim import Simulator
from flight.vehicle import VehicleClient, VehicleConnectionError
from tests.flight.attacks.conftest import Attacker
from tests.waiting import CONNECT_S, wait_for_async

FAST_FORWARD = 20.0


def run(coro, timeout_s=60.0):
    async def bounded():
        return await asyncio.wait_for(coro, timeout_s)

    return asyncio.run(bounded())


@pytest.fixture
def key():
    return new_key()


@pytest.fixture
def vehicle(key):
    v = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None, signing_key=key)
    v.start(speed=FAST_FORWARD)
    try:
        yield v
    finally:
        v.close()


def _spoof_position(spoofer, client_address, lat, lon, alt_m, home_alt_msl):
    """A GLOBAL_POSITION_INT claiming to be the vehicle (system 1, component 1), sent to the client."""
    msg = spoofer.mav.global_position_int_encode(
        0, round(lat * 1e7), round(lon * 1e7), round((home_alt_msl + alt_m) * 1000), round(alt_m * 1000), 0, 0, 0, 0
    )
    spoofer.raw(spoofer.pack(msg), to=client_address)


@pytest.mark.parametrize("signing", [True, False], ids=["signed", "unsigned"])
def test_spoofed_telemetry_from_another_socket_cannot_end_a_goto(key, signing):
    home_alt = 300.0
    v = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None, signing_key=key if signing else None)
    v.start(speed=FAST_FORWARD)
    spoofer = Attacker(v.address, system_id=1)
    spoofer.mav.srcComponent = 1

    async def fly():
        async with await VehicleClient.connect(
            v.address, timeout_s=CONNECT_S, signing_key=key if signing else None
        ) as c:
            assert (await c.arm()).ok and (await c.takeoff(5.0)).ok
            start = c.telemetry
            assert start.lat_deg is not None and start.lon_deg is not None
            lat, lon = offset_position(start.lat_deg, start.lon_deg, 500.0, 0.0)
            stop = asyncio.Event()

            async def flood():
                while not stop.is_set():
                    _spoof_position(spoofer, c.address, lat, lon, 5.0, home_alt)
                    await asyncio.sleep(0.01)

            task = asyncio.create_task(flood())
            try:
                result = await c.goto(lat, lon, 5.0, timeout_s=2.0)
            finally:
                stop.set()
                await task
            truth = v.sim.state()
            north, _ = local_offset(lat, lon, truth.lat_deg, truth.lon_deg)
            assert not result.ok and abs(north) > 300.0  # the vehicle is far from the target, and goto says so
            told = c.telemetry
            assert told.lat_deg is not None and told.lon_deg is not None
            assert abs(local_offset(lat, lon, told.lat_deg, told.lon_deg)[0]) > 300.0  # it never believed the spoof
            assert c.link_report()["foreign"] > 0

    try:
        run(fly())
    finally:
        spoofer.close()
        v.close()


def test_the_signed_client_flies_the_signed_vehicle_and_a_wrong_key_is_not_heard(vehicle, key):
    async def fly():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S, signing_key=key) as client:
            assert (await client.arm()).ok and (await client.takeoff(5.0)).ok
            assert (await client.goto_local(20.0, 0.0, 5.0)).ok
            assert (await client.land()).ok
            report = client.link_report()
            assert report["signed"] > 50 and report["unsigned"] == report["bad_signature"] == 0
        assert vehicle.security()["signed"] >= 4 and vehicle.security()["unsigned"] == 0  # its 4 commands at least
        with pytest.raises(VehicleConnectionError):  # every heartbeat is refused: no vehicle is found
            await VehicleClient.connect(vehicle.address, timeout_s=1.5, signing_key=new_key())

    run(fly())


def test_an_unsigned_client_cannot_command_a_signed_vehicle(vehicle):
    async def try_it():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S, ack_timeout_s=0.3) as client:
            result = await client.arm()  # it hears the vehicle (it does not check), but is not obeyed
            assert not result.ok and not vehicle.sim.armed
            await wait_for_async(lambda: vehicle.security()["unsigned"] >= 3, 5.0, what="refusals counted")

    run(try_it())


def test_a_spoofer_heartbeat_does_not_bind_a_listening_client(key):
    """A client listening (udpin) takes the vehicle's address from its first *signed* heartbeat."""
    from tests.flight.test_client import free_udp_port

    port = free_udp_port()
    spoofer = Attacker(("127.0.0.1", port), system_id=1)
    spoofer.mav.srcComponent = 1
    v = MavlinkVehicle(Simulator(seed=5), gcs=("127.0.0.1", port), api=None, signing_key=key)

    async def listen():
        connecting = asyncio.create_task(VehicleClient.connect(f"udpin:127.0.0.1:{port}", 5.0, signing_key=key))
        for _ in range(5):
            spoofer.send(spoofer.mav.heartbeat_encode(mavlink2.MAV_TYPE_QUADROTOR, mavlink2.MAV_AUTOPILOT_PX4, 0, 0, 0))
            await asyncio.sleep(0.02)
        v.start(speed=FAST_FORWARD)
        client = await connecting
        async with client:
            assert client.remote == v.address
            assert client.link_report()["unsigned"] >= 1

    try:
        run(listen())
    finally:
        spoofer.close()
        v.close()
