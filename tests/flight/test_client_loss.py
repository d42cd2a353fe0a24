"""One lost datagram does not fail what a careful ground station completes: a land or a return whose COMMAND_ACK
was lost (the vehicle, faster than the wall clock, had done it before the copy sent again was refused), and a
clear the vehicle ignored as busy while it held a download open whose closing MISSION_ACK was lost."""

from typing import Any

import pytest

from agentic_core.contracts.geodesy import offset_position
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from flight.vehicle import MissionItem, VehicleClient
from tests.waiting import CONNECT_S, wait_for_async

from .conftest import FAST_FORWARD
from .test_client import run
from .test_client_mission import LossyRelay

COMMAND_ACK, MISSION_ACK, MISSION_CURRENT = 77, 47, 42


@pytest.fixture
def vehicle_seed() -> int:
    return 11


@pytest.fixture
def relay(vehicle):
    r = LossyRelay(vehicle.address, {})
    yield r
    r.close()


@pytest.mark.parametrize("action", ["land", "rtl"])
def test_a_land_or_return_whose_ack_was_lost_is_done_not_denied(vehicle, relay, action):
    home = vehicle.sim.environment.home

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert await client.set_param("RTL_RETURN_ALT", 5.0) == 5.0  # a short return, over before the resend
            assert (await client.arm()).ok and (await client.takeoff(6.0)).ok
            assert (await client.goto(*offset_position(home.lat_deg, home.lon_deg, 5.0, 0.0), 6.0)).ok
            relay.drop = {COMMAND_ACK: 1}
            done = await getattr(client, action)()
            assert relay.dropped == [COMMAND_ACK]
            return done

    done = run(go(), timeout_s=90.0)
    assert done.status == "ok" and done.reached, done  # before: denied, 'Land denied: not armed'
    assert not vehicle.sim.armed and vehicle.sim.truth().on_ground


def test_a_clear_ignored_as_busy_after_a_lost_closing_ack_waits_it_out(vehicle, relay):
    home = vehicle.sim.environment.home
    items = [MissionItem.waypoint(*offset_position(home.lat_deg, home.lon_deg, 10.0 * k, 0.0), 10.0) for k in (1, 2)]

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert (await client.upload_mission(items)).ok
            relay.drop = {MISSION_ACK: 1}
            assert (await client.download_mission()).count == len(items)
            await wait_for_async(lambda: relay.dropped == [MISSION_ACK], 5.0, what="the closing ACK lost")
            cleared = await client.clear_mission()  # ignored with 'WPM: IGN CLEAR CMD: Busy' until the timeout
            return cleared, await client.download_mission()

    cleared, after = run(go(), timeout_s=60.0)
    assert cleared.status == "ok", cleared.reason  # before: timeout, 'no answer from the vehicle to the clear'
    assert after.ok and after.count == 0


def test_a_fresh_client_that_misses_two_mission_reports_still_restarts_a_finished_mission():
    """A client new to a vehicle whose mission has flown to its end learns that from MISSION_CURRENT (1 Hz) and sets
    item 0 before MISSION_START; with the first two reports lost it asks for one (REQUEST_MESSAGE) instead of
    starting the finished plan at its end, which armed the vehicle on the ground and flew nothing."""
    speed = [FAST_FORWARD]
    v = MavlinkVehicle(Simulator(seed=11), gcs=None, api=None)
    v.start(speed=lambda: speed[0])
    home = v.sim.environment.home
    items = [MissionItem.takeoff(6.0), MissionItem.waypoint(*offset_position(home.lat_deg, home.lon_deg, 8, 0), 6.0)]
    lossy = LossyRelay(v.address, {})

    async def go() -> None:
        async with await VehicleClient.connect(v.address, timeout_s=CONNECT_S) as first:  # flown once, to its end
            assert (await first.upload_mission(items)).ok and (await first.start_mission()).ok
            assert (await first.wait_mission(timeout_s=60.0)).ok
            assert (await first.land()).ok
        speed[0] = 1.0  # real time, as a vehicle is: the 1 Hz reports are a second apart
        lossy.drop = {MISSION_CURRENT: 2}
        async with await VehicleClient.connect(lossy.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as fresh:
            assert (await fresh.start_mission()).ok
            await wait_for_async(lambda: -v.sim.state().down_m > 3.0, 15.0, what="the mission flown again")

    try:
        run(go(), timeout_s=90.0)
        assert lossy.dropped == [MISSION_CURRENT, MISSION_CURRENT]
    finally:
        lossy.close()
        v.close()


@pytest.mark.parametrize(
    ("lost", "expected"),
    [(None, "A" * 50 + "B" * 50 + "tail"), (0, "[…]" + "B" * 50 + "tail"), (1, "A" * 50 + "[…]tail")],
)
def test_a_long_statustext_with_a_chunk_lost_shows_the_gap(lost, expected):
    """A text of more than 50 bytes comes in numbered chunks; one lost, the reason built from it says a part is
    missing (it read as if whole: 'upported with a position')."""
    from pymavlink.dialects.v20 import common as mavlink2

    from flight.client.telemetry import TelemetryStore

    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    chunks = ["A" * 50, "B" * 50, "tail"]
    store = TelemetryStore()
    for seq in range(len(chunks)):
        if seq != lost:
            msg = mav.statustext_encode(4, chunks[seq].encode(), 7, seq)
            msg.pack(mav)  # stamps the sender, as a received message carries it
            store.fold(msg, own_component=True)
    assert store.texts_since(0) == [expected]


def test_a_plan_the_vehicle_will_not_fly_is_denied_with_three_mission_reports_lost():
    """After an accepted upload the next MISSION_CURRENT says whether the plan may fly (PX4 stores a plan past the
    geofence, then reports NO_MISSION). With the 1 Hz reports alone, three lost at real time passed it as ``ok``;
    the client asks for a report at once, a third and two thirds of the way (with two asks, a slow report made three
    messages in the wait, and three lost were all of them: a one-off failure in a fresh clone)."""
    v = MavlinkVehicle(Simulator(seed=11), gcs=None, api=None)
    v.start(speed=1.0)
    home = v.sim.environment.home
    far = [MissionItem.takeoff(10.0), MissionItem.waypoint(*offset_position(home.lat_deg, home.lon_deg, 150, 0), 10)]
    lossy = LossyRelay(v.address, {})

    async def go() -> Any:
        async with await VehicleClient.connect(lossy.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert await client.set_param("GF_MAX_HOR_DIST", 100.0) == 100.0
            lossy.drop = {MISSION_CURRENT: 3}
            return await client.upload_mission(far)

    try:
        up = run(go(), timeout_s=60.0)
    finally:
        lossy.close()
        v.close()
    assert lossy.dropped == [MISSION_CURRENT] * 3
    assert up.status == "denied" and "Geofence violation for waypoint 2" in up.reason, up
