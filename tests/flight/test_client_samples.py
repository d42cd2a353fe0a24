"""The client's TelemetrySamples: Telemetry.sample(), stream rates raised for a camera, on_sample callbacks."""

import asyncio
import math
import queue
import threading
import time

import pytest

from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.telemetry import TelemetrySample
from flight.client.streams import interval_us, message_id
from flight.client.telemetry import Telemetry
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from flight.vehicle import CAMERA_STREAMS, VehicleClient
from tests.waiting import CONNECT_S

from .test_client import run


@pytest.fixture
def realtime_vehicle():
    v = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None)
    v.start(speed=1.0)
    try:
        yield v
    finally:
        v.close()


def test_no_sample_until_a_position_is_known():
    assert Telemetry(connected=True).sample() is None
    half = Telemetry(connected=True, lat_deg=21.4, lon_deg=39.9, alt_m=3.0)  # no LOCAL_POSITION_NED yet
    assert half.sample() is None


def test_message_names_and_rates_are_checked_before_anything_is_sent():
    assert message_id("attitude") == 30 and message_id(33) == 33
    for bad in ("NOT_A_MESSAGE", 999_999):
        with pytest.raises(ValueError):
            message_id(bad)
    assert interval_us(None) == 0 and interval_us(0) == -1 and interval_us(30) == pytest.approx(33_333.3, abs=0.1)
    for rate in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError):
            interval_us(rate)


def test_camera_rates_and_a_callback_per_sample_on_another_thread(realtime_vehicle):
    inbox: queue.Queue[tuple[TelemetrySample, str]] = queue.Queue()

    async def fly():
        async with await VehicleClient.connect(realtime_vehicle.address, timeout_s=CONNECT_S) as client:
            assert await client.wait_telemetry(5.0) is not None
            cancel = client.on_sample(lambda s: inbox.put((s, threading.current_thread().name)))

            def broken(sample: TelemetrySample) -> None:
                raise ZeroDivisionError("subscriber bug")

            client.on_sample(broken)  # recorded; the others go on
            accepted = await client.set_stream_rates({name: 30.0 for name in CAMERA_STREAMS})
            assert accepted == {30: True, 33: True, 32: True}
            assert realtime_vehicle.message_rate_hz(33, client.address) == pytest.approx(30.0)  # its link only
            assert realtime_vehicle.message_rate_hz(33) == pytest.approx(5.0)
            refused = await client.set_stream_rates({"PARAM_VALUE": 5.0})  # not a stream: the vehicle says no
            assert refused == {22: False}
            while not inbox.empty():
                inbox.get_nowait()
            deadline = time.monotonic() + 5.0
            while inbox.qsize() < 46 and time.monotonic() < deadline:  # 1.5 s of real-time flight at 30 Hz
                await asyncio.sleep(0.02)
            got: list[tuple[TelemetrySample, str]] = []
            while not inbox.empty():
                got.append(inbox.get_nowait())
            snapshot = client.telemetry.sample()
            errors = list(client.sample_errors)
            cancel()
            cancel()  # idempotent
            return got, snapshot, errors

    got, snapshot, errors = run(fly())
    assert len(got) >= 46, len(got)
    times = [s.time_s for s, _ in got]
    assert times == sorted(times) and len(set(times)) == len(times)
    rate_hz = (len(times) - 1) / (times[-1] - times[0])  # on the vehicle's clock
    assert 27.0 < rate_hz < 33.0, rate_hz
    assert {thread for _, thread in got} == {"mavlink-client"}  # the client's reader thread
    s = got[-1][0]
    assert abs(s.lat_deg - 21.4133) < 1e-4 and abs(s.alt_m) < 0.5 and s.mode == "hold" and not s.armed
    assert s.landed_state == "on_ground" and s.battery_pct is not None and s.battery_pct > 90
    assert snapshot is not None and snapshot.time_s >= s.time_s
    assert errors and "ZeroDivisionError" in errors[0]


def test_attitude_reaches_the_sample_in_flight():
    v = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None)
    v.start(speed=10.0)

    async def fly():
        async with await VehicleClient.connect(v.address, timeout_s=CONNECT_S) as client:
            assert (await client.arm()).ok
            assert (await client.takeoff(6.0)).ok
            lat, lon = client.telemetry.lat_deg, client.telemetry.lon_deg
            assert lat is not None and lon is not None
            tlat, tlon = offset_position(lat, lon, 60.0, 0.0)
            leg = asyncio.ensure_future(client.goto(tlat, tlon, 6.0))

            def nose_down_on_the_leg(_msg):
                st = client._state
                return True if (st.north_m or 0.0) > 3.0 and (st.pitch_deg or 0.0) < -5.0 else None

            tilted = await client._wait(nose_down_on_the_leg, 20.0)
            sample = client.telemetry.sample()
            await leg
            return tilted, sample

    try:
        tilted, sample = run(fly(), timeout_s=60.0)
    finally:
        v.close()
    assert tilted and sample is not None
    assert sample.pitch_deg < -2.0 and sample.alt_m > 5.0 and sample.armed and sample.mode == "hold"
    assert sample.north_m > 0.0 and sample.time_s > 0.0


def test_samples_carry_the_gps_fix_and_the_wind_estimate_and_so_does_the_vehicle_own_sample():
    """GPS_RAW_INT (fix type, satellites) and WIND_COV (the wind estimate) reach a client's samples, with the same
    values the in-process vehicle hands its own samples; a GPS that loses its fix says so."""
    from flight.sim.environment import Environment, WindSettings

    sim = Simulator(seed=3, environment=Environment(wind=WindSettings(north_mps=3.0, east_mps=-4.0)))
    vehicle = MavlinkVehicle(sim, gcs=None, api=None)
    vehicle.start(speed=None)
    try:

        async def listen():
            async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
                deadline = time.monotonic() + 10.0
                while time.monotonic() < deadline:
                    await asyncio.sleep(0.05)
                    last = client.telemetry.sample()
                    if last is not None and last.wind_mps is not None and last.gps_fix_type is not None:
                        break
                healthy = client.telemetry.sample()
                vehicle.sim.gps_lost = True
                while time.monotonic() < deadline and client.telemetry.gps_fix_type != 0:
                    await asyncio.sleep(0.05)
                return healthy, client.telemetry.sample()

        healthy, lost = run(listen())
    finally:
        vehicle.close()
    assert healthy is not None and lost is not None
    assert healthy.gps_fix_type == 3 and healthy.gps_satellites == 12
    assert (healthy.wind_north_mps, healthy.wind_east_mps) == pytest.approx((3.0, -4.0), abs=1e-4)
    assert healthy.wind_mps == pytest.approx(5.0, abs=1e-4)
    assert lost.gps_fix_type == 0 and lost.gps_satellites == 0
    own = vehicle.telemetry_sample()
    assert own.wind_mps == pytest.approx(5.0) and own.gps_fix_type == 0
