"""The agent's client (flight.vehicle) and the mission protocol: uploads, downloads, refusals, lost messages and a
mission flown, against the simulated vehicle running on a thread."""

import asyncio
import math
import socket
import threading
from typing import Any

import pytest

from agentic_core.contracts.geodesy import local_offset, offset_position
from flight.vehicle import MissionItem, MissionType, VehicleClient
from tests.waiting import CONNECT_S, wait_for_async

from .test_client import run

HOME = (21.4133, 39.8933)


def at(north: float, east: float) -> tuple[float, float]:
    return offset_position(*HOME, north, east)


@pytest.fixture
def vehicle_seed() -> int:
    return 11


def same_item(a: MissionItem, b: MissionItem) -> bool:
    def close(x, y, tol):
        return (math.isnan(x) and math.isnan(y)) or abs(x - y) <= tol

    fields = ("param1", "param2", "param3", "param4", "param7", "alt")
    return (
        (a.command, a.frame, a.autocontinue) == (b.command, b.frame, b.autocontinue)
        and all(close(getattr(a, f), getattr(b, f), 1e-6) for f in fields)
        and close(a.lat or 0.0, b.lat or 0.0, 2e-7)
        and close(a.lon or 0.0, b.lon or 0.0, 2e-7)
    )


def test_plans_go_up_and_come_back_and_clear(vehicle):
    mission = [
        MissionItem.takeoff(12.0),
        MissionItem.waypoint(*at(40, 0), 12.0, hold_s=1.5, acceptance_m=1.0),
        MissionItem.change_speed(7.0),
        MissionItem.loiter(*at(40, 40), 15.0, seconds=3.0),
        MissionItem.release_payload(),
        MissionItem.loiter(*at(0, 40), 15.0),
        MissionItem.rtl(),
    ]
    fence = [
        *MissionItem.fence_polygon([at(-200, -200), at(-200, 200), at(200, 200), at(200, -200)]),
        MissionItem.fence_circle(*at(100, 100), 20.0, inclusion=False),
    ]
    rally = [MissionItem.rally_point(*at(-30, 0), 20.0)]

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            plans: list[tuple[list[MissionItem], MissionType]] = [
                (mission, "mission"),
                (fence, "fence"),
                (rally, "rally"),
            ]
            for items, kind in plans:
                up: Any = await client.upload_mission(items, mission_type=kind)
                assert up.ok and up.result == "MAV_MISSION_ACCEPTED" and up.count == len(items), up
                down: Any = await client.download_mission(mission_type=kind)
                assert down.ok and down.count == len(items) and down.mission_type == kind
                assert all(same_item(a, b) for a, b in zip(items, down.items, strict=True)), down.items
            assert client.telemetry.mission_total == len(mission)
            cleared: Any = await client.clear_mission(mission_type="fence")
            assert cleared.ok and cleared.result == "MAV_MISSION_ACCEPTED"
            assert (await client.download_mission(mission_type="fence")).count == 0
            assert (await client.download_mission()).count == len(mission)  # the other plans are untouched
            assert (await client.clear_mission(mission_type=None)).ok  # all three
            assert [(await client.download_mission(mission_type=k)).count for k in ("mission", "rally")] == [0, 0]

    run(go())


def test_refusals_come_back_as_denied_with_the_result_and_the_reason(vehicle):
    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            turns = MissionItem(command=18, lat=at(10, 0)[0], lon=at(10, 0)[1], alt=10.0)  # LOITER_TURNS: not PX4's
            bad: Any = await client.upload_mission([MissionItem.takeoff(10.0), turns])
            assert bad.status == "denied" and bad.result == "MAV_MISSION_UNSUPPORTED"
            assert "Invalid item 1" in bad.reason
            assert (await client.download_mission()).count == 0  # nothing was stored
            assert await client.set_param("GF_MAX_HOR_DIST", 100.0) == 100.0
            far: Any = await client.upload_mission([MissionItem.takeoff(10.0), MissionItem.waypoint(*at(150, 0), 10)])
            assert far.status == "denied" and far.result == "MAV_MISSION_ACCEPTED"  # stored, but it will not fly
            assert "Geofence violation for waypoint 2" in far.reason
            start: Any = await client.start_mission()
            assert start.status == "denied" and "No valid mission" in start.reason and not start.state.armed
            with pytest.raises(ValueError):
                MissionItem(command=16, frame=2, lat=21.0, lon=39.0)  # a position in a frame without one

    run(go())


def test_a_mission_is_flown_from_the_client(vehicle):
    waypoints = [(35.0, 0.0, 10.0), (35.0, 35.0, 14.0), (0.0, 35.0, 12.0)]
    items = [MissionItem.takeoff(10.0)]
    items += [MissionItem.waypoint(*at(n, e), alt) for n, e, alt in waypoints[:2]]
    items += [MissionItem.change_speed(8.0), MissionItem.release_payload()]
    items += [MissionItem.waypoint(*at(*waypoints[2][:2]), waypoints[2][2]), MissionItem.land()]

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert (await client.upload_mission(items)).ok
            positions: list[tuple[float, float, float]] = []
            sub = client.subscribe()

            async def watch():
                async for t in sub:
                    if t.lat_deg is not None and t.lon_deg is not None and t.alt_m is not None:
                        positions.append((*local_offset(*HOME, t.lat_deg, t.lon_deg), t.alt_m))

            watcher = asyncio.create_task(watch())
            started: Any = await client.start_mission()
            assert started.ok and started.reached and started.state.mission_state == "active"
            done: Any = await client.wait_mission(timeout_s=60.0)
            sub.close()
            await asyncio.wait_for(watcher, 2.0)
            assert done.ok, done.reason
            assert done.state.mission_state == "complete" and done.state.mission_reached == len(items) - 1
            landed = await client._wait(lambda _m: True if not client._state.armed else None, 20.0)
            assert landed and abs(client.telemetry.alt_m or 0.0) < 0.3  # touched down and disarmed, as PX4
            for n, e, alt in waypoints:  # each waypoint was passed close by, at its height
                near = [p for p in positions if math.hypot(p[0] - n, p[1] - e) < 3.0]  # (the landing is near one)
                assert any(abs(p[2] - alt) < 1.5 for p in near), (n, e, alt, near[:5])
            assert vehicle.sim.payload_released
            assert vehicle.navigator.cruise_speed_mps == 8.0

    run(go(), timeout_s=90.0)


class LossyRelay:
    """A UDP relay between a client and the vehicle that drops the first datagram of chosen MAVLink messages."""

    def __init__(self, vehicle_address, drop):
        self.vehicle = vehicle_address
        self.drop = dict(drop)  # message id -> how many to drop
        self.dropped = []
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.client = None
        self.stopped = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)
        self.thread.start()

    @property
    def address(self):
        return self.sock.getsockname()

    def run(self):
        while not self.stopped.is_set():
            try:
                data, sender = self.sock.recvfrom(65535)
            except (TimeoutError, OSError):
                continue
            msg_id = int.from_bytes(data[7:10], "little") if data[:1] == b"\xfd" and len(data) > 10 else -1
            if self.drop.get(msg_id, 0) > 0:
                self.drop[msg_id] -= 1
                self.dropped.append(msg_id)
                continue
            if sender == self.vehicle:
                if self.client is not None:
                    self.sock.sendto(data, self.client)
            else:
                self.client = sender
                self.sock.sendto(data, self.vehicle)

    def close(self):
        self.stopped.set()
        self.thread.join(2.0)
        self.sock.close()


def test_lost_mission_messages_are_sent_again(vehicle):
    item_int, request_int, count = 73, 51, 44
    relay = LossyRelay(vehicle.address, {item_int: 2, request_int: 1, count: 1})
    items = [MissionItem.waypoint(*at(10 * k, 0), 10.0) for k in range(1, 5)]

    async def go():
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            up: Any = await client.upload_mission(items)
            assert up.ok, up.reason
            assert sorted(relay.dropped) == [count, request_int, item_int, item_int]  # both directions lost some
            assert up.resends >= 1  # the lost MISSION_COUNT was ours to send again; the vehicle re-asked the rest
            down: Any = await client.download_mission()
            assert down.ok and down.count == len(items)
            assert all(same_item(a, b) for a, b in zip(items, down.items, strict=True))

    try:
        run(go())
    finally:
        relay.close()


@pytest.mark.parametrize("lost", ["the set", "its answer"])
def test_a_lost_parameter_set_is_sent_again(vehicle, lost):
    """PARAM_SET has no acknowledgement but the PARAM_VALUE echo: a fence whose limit or whose echo is lost on the
    way is still set (before, one lost datagram ended a run with 'no answer to setting GF_MAX_VER_DIST')."""
    param_value, param_set = 22, 23
    relay = LossyRelay(vehicle.address, {})
    home = vehicle.sim.environment.home

    async def go():
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert await client.get_param("GF_MAX_VER_DIST") is not None  # its type is known: the next is one set
            relay.drop = {param_set: 1} if lost == "the set" else {param_value: 1}
            assert await client.set_param("GF_MAX_VER_DIST", 33.0, timeout_s=3.0) == 33.0
            assert relay.dropped == [param_set if lost == "the set" else param_value]
            relay.drop = {param_set: 2}
            fence = await client.upload_fence(circle=(home.lat_deg, home.lon_deg, 150.0), max_alt_m=40.0)
            assert fence.status == "ok", fence.reason
            assert fence.params["GF_MAX_VER_DIST"] == 40.0

    try:
        run(go())
    finally:
        relay.close()


def test_a_set_is_answered_by_its_own_echo_not_an_earlier_reads(vehicle):
    """A read answered just before a set reaches the set's waiter too (the match is by name): the set waits for
    its own echo rather than return the old value; an armed vehicle that keeps its safety limit on an unsigned
    link echoes the old value, and that is what the set returns, once its try's time is up."""

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            old = await client.get_param("GF_MAX_VER_DIST")
            assert old is not None
            read, echoed = await asyncio.gather(
                client.get_param("GF_MAX_VER_DIST"), client.set_param("GF_MAX_VER_DIST", old + 7.0)
            )
            assert (read, echoed) == (old, old + 7.0)
            assert (await client.arm()).status == "ok"
            assert await client.set_param("GF_MAX_VER_DIST", old + 20.0, timeout_s=1.5) == old + 7.0  # kept

    run(go())


def test_an_upload_after_a_download_whose_closing_ack_was_lost_waits_it_out(vehicle):
    """The client's MISSION_ACK that ends a download lost, the vehicle holds the transfer open until its protocol
    timeout and refuses the next upload as busy ("WPM: IGN MISSION_COUNT: Busy"): the upload waits that out on
    the vehicle's clock and goes through (before, it was denied, and a run setting its fence failed)."""
    ack = 47
    relay = LossyRelay(vehicle.address, {})
    items = [MissionItem.waypoint(*at(10 * k, 0), 10.0) for k in range(1, 4)]

    async def go():
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert (await client.upload_mission(items)).ok
            relay.drop = {ack: 1}
            assert (await client.download_mission()).count == len(items)
            await wait_for_async(lambda: relay.dropped == [ack], 5.0, what="the download's closing ACK lost")
            up: Any = await client.upload_mission(items[:2])
            assert up.ok, up.reason
            down: Any = await client.download_mission()
            assert down.ok and down.count == 2

    try:
        run(go())
    finally:
        relay.close()


def test_a_silent_vehicle_makes_transfers_time_out(vehicle):
    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S, ack_timeout_s=0.1) as client:
            vehicle.stop()  # the socket stays open, nothing answers
            up: Any = await client.upload_mission([MissionItem.waypoint(*at(10, 0), 10.0)])
            assert up.status == "timeout" and up.result is None and "no answer" in up.reason
            assert up.resends == 5  # the MAVLink guide's five retries, then the upload was cancelled
            down: Any = await client.download_mission()
            assert down.status == "timeout" and down.items == []

    run(go())


def test_a_finished_mission_starts_over_and_can_start_from_an_item(vehicle):
    items = [MissionItem.takeoff(6.0), MissionItem.waypoint(*at(8, 0), 6.0), MissionItem.waypoint(*at(8, 8), 6.0)]

    runner = vehicle.navigator.mission
    set_current, chosen = runner.set_current, []

    def recording(seq: int, reset_jumps: bool = False) -> bool:
        chosen.append(seq)
        return bool(set_current(seq, reset_jumps))

    runner.set_current = recording
    seqs: list[int] = []  # the vehicle's current item tick by tick (item 1 takes many ticks: it is 8 m away)
    vehicle.on_tick.append(lambda _state: seqs.append(runner.store.current_seq))

    async def go():
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as client:
            assert (await client.upload_mission(items)).ok
            assert (await client.start_mission()).ok
            first: Any = await client.wait_mission(timeout_s=60.0)
            assert first.ok and first.state.mission_reached == 2
        finished_at = len(seqs)
        async with await VehicleClient.connect(vehicle.address, timeout_s=CONNECT_S) as fresh:  # knows nothing yet
            again: Any = await fresh.start_mission()
            assert again.ok, again.reason
            assert again.state.mission_state in ("active", "complete")
            assert chosen == [0]  # the client saw the mission complete and set item 0 first
            second: Any = await fresh.wait_mission(timeout_s=60.0)
            assert second.ok and vehicle.mode.name == "HOLD"
            assert 1 in seqs[finished_at:], "the finished mission did not fly its items again"
            assert (await fresh.start_mission(from_item=2)).ok
            third: Any = await fresh.wait_mission(timeout_s=60.0)
            assert third.ok and chosen == [0, 2]
            bad: Any = await fresh.start_mission(from_item=7)
            assert bad.status == "failed" and bad.ack == 4  # MAV_RESULT_FAILED: no item 7

    run(go(), timeout_s=90.0)
