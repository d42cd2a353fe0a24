"""Duplicated and reordered datagrams, as redundant links (mavlink-router over two radios) and radio retries deliver
them: every message in each direction copied, a copy kept back and delivered during a later operation of the same
kind, two messages swapped. The client must complete what a careful ground station completes and report what the
vehicle did, never a stale answer to an earlier request as the answer to the one in hand."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from agentic_core.contracts.geodesy import offset_position
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from flight.vehicle import MissionItem, VehicleClient
from tests.waiting import CONNECT_S, wait_for_async

from .conftest import FAST_FORWARD
from .test_client import run
from .test_client_mission import LossyRelay, same_item

Match = Callable[[Any, bool], bool]
"""A predicate over a relayed message and whether it goes to the vehicle."""


def kind(name: str, *, to_vehicle: bool | None = None, **fields: Any) -> Match:
    """Messages of type ``name`` (going the given way, with the given field values)."""

    def match(msg: Any, towards_vehicle: bool) -> bool:
        if msg.get_type() != name or (to_vehicle is not None and towards_vehicle != to_vehicle):
            return False
        return all(getattr(msg, field, None) == value for field, value in fields.items())

    return match


class Rule:
    """What the relay does to the next ``times`` datagrams matching ``match``."""

    def __init__(self, match: Match, times: int) -> None:
        self.match, self.times = match, times

    def take(self, msg: Any, to_vehicle: bool) -> bool:
        if self.times > 0 and self.match(msg, to_vehicle):
            self.times -= 1
            return True
        return False


class DuplicatingRelay(LossyRelay):
    """:class:`LossyRelay` that also copies datagrams (delivered at once, or kept back until a later datagram
    passes) and delays one past the next going the same way (a swap)."""

    def __init__(self, vehicle_address: Any) -> None:
        self.copies: list[tuple[Rule, int]] = []
        self.stashes: list[Rule] = []
        self.stashed: list[tuple[bytes, bool]] = []
        self.releases: list[Rule] = []
        self.delays: list[Rule] = []
        self.delayed: list[tuple[bytes, bool]] = []
        self.losses: list[Rule] = []
        self.copied: list[str] = []
        """The type of every message copied (at once or kept back), in order."""
        self.released = 0
        self._parser = mavlink2.MAVLink(None)
        self._parser.robust_parsing = True
        super().__init__(vehicle_address, {})

    def duplicate(self, match: Match, *, copies: int = 1, times: int = 1) -> None:
        """The next ``times`` datagrams matching go ``1 + copies`` times, back to back."""
        self.copies.append((Rule(match, times), copies))

    def keep_copy(self, match: Match, *, times: int = 1) -> None:
        """The next ``times`` datagrams matching go on, and a copy of each is kept back for :meth:`release_before`."""
        self.stashes.append(Rule(match, times))

    def release_before(self, match: Match) -> None:
        """The copies kept back are delivered just before the next datagram matching (which then goes on)."""
        self.releases.append(Rule(match, 1))

    def lose(self, match: Match, *, times: int = 1) -> None:
        """The next ``times`` datagrams matching are dropped (one way, one type and its fields: finer than ``drop``)."""
        self.losses.append(Rule(match, times))

    def delay(self, match: Match, *, times: int = 1) -> None:
        """The next ``times`` datagrams matching go just after the next datagram going the same way."""
        self.delays.append(Rule(match, times))

    def _message(self, data: bytes) -> Any | None:
        try:
            msgs = self._parser.parse_buffer(data) or []
        except Exception:
            return None
        return next((m for m in msgs if m.get_type() != "BAD_DATA"), None)

    def _deliver(self, data: bytes, to_vehicle: bool) -> None:
        if to_vehicle:
            self.sock.sendto(data, self.vehicle)
        elif self.client is not None:
            self.sock.sendto(data, self.client)

    def run(self) -> None:
        while not self.stopped.is_set():
            try:
                data, sender = self.sock.recvfrom(65535)
            except (TimeoutError, OSError):
                continue
            to_vehicle = sender != self.vehicle
            if to_vehicle:
                self.client = sender
            msg = self._message(data)
            if msg is None:
                self._deliver(data, to_vehicle)
                continue
            if self.drop.get(msg.get_msgId(), 0) > 0 or any(rule.take(msg, to_vehicle) for rule in self.losses):
                self.drop[msg.get_msgId()] = max(0, self.drop.get(msg.get_msgId(), 0) - 1)
                self.dropped.append(msg.get_msgId())
                continue
            if any(rule.take(msg, to_vehicle) for rule in self.releases):
                for copy, way in self.stashed:
                    self._deliver(copy, way)
                    self.released += 1
                self.stashed.clear()
            if any(rule.take(msg, to_vehicle) for rule in self.delays):
                self.delayed.append((data, to_vehicle))
                continue
            self._deliver(data, to_vehicle)
            for copy, way in [d for d in self.delayed if d[1] == to_vehicle]:
                self._deliver(copy, way)
            self.delayed = [d for d in self.delayed if d[1] != to_vehicle]
            for rule, copies in self.copies:
                if rule.take(msg, to_vehicle):
                    self.copied.append(msg.get_type())
                    for _ in range(copies):
                        self._deliver(data, to_vehicle)
            if any(rule.take(msg, to_vehicle) for rule in self.stashes):
                self.copied.append(msg.get_type())
                self.stashed.append((data, to_vehicle))


def everything(msg: Any, to_vehicle: bool) -> bool:
    return True


@pytest.fixture
def vehicle_seed() -> int:
    return 11


@pytest.fixture
def relay(vehicle):
    r = DuplicatingRelay(vehicle.address)
    yield r
    r.close()


def near_home(vehicle: MavlinkVehicle, north: float, east: float) -> tuple[float, float]:
    home = vehicle.sim.environment.home
    return offset_position(home.lat_deg, home.lon_deg, north, east)


def plans(vehicle: MavlinkVehicle) -> dict[str, list[MissionItem]]:
    at = lambda n, e: near_home(vehicle, n, e)  # noqa: E731
    return {
        "mission": [MissionItem.takeoff(6.0), *(MissionItem.waypoint(*at(8.0 * k, 0.0), 6.0) for k in (1, 2, 3))],
        "fence": MissionItem.fence_polygon([at(-300, -300), at(-300, 300), at(300, 300), at(300, -300)]),
        "rally": [MissionItem.rally_point(*at(-20.0, 0.0), 15.0), MissionItem.rally_point(*at(20.0, 0.0), 15.0)],
    }


def stored(vehicle: MavlinkVehicle, mission_type: str) -> int:
    return vehicle.missions.store.count({"mission": 0, "fence": 1, "rally": 2}[mission_type])


@pytest.mark.parametrize("copies", [1, 3])
def test_every_message_duplicated_both_ways_still_flies_and_transfers(vehicle, relay, copies):
    """Every datagram in both directions delivered ``1 + copies`` times: each operation completes and says what
    the vehicle did (the vehicle acts on a copied command again, which arm, take-off, go-to, land and a set are
    made to bear: the same command twice is the same command)."""
    relay.duplicate(everything, copies=copies, times=10**9)

    async def go() -> None:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            for mission_type, items in plans(vehicle).items():
                up: Any = await client.upload_mission(items, mission_type=mission_type)  # type: ignore[arg-type]
                assert up.ok, (mission_type, up.reason)
                assert stored(vehicle, mission_type) == len(items)
                down: Any = await client.download_mission(mission_type=mission_type)  # type: ignore[arg-type]
                assert down.ok and all(same_item(a, b) for a, b in zip(items, down.items, strict=True)), down
            assert (await client.clear_mission(mission_type="rally")).ok and stored(vehicle, "rally") == 0
            assert await client.set_param("MPC_XY_CRUISE", 6.0) == 6.0 and vehicle.params["MPC_XY_CRUISE"] == 6.0
            assert await client.get_param("MPC_XY_CRUISE") == 6.0
            assert (await client.arm()).ok and (await client.takeoff(5.0)).ok
            assert (await client.goto(*near_home(vehicle, 6.0, 0.0), 5.0)).ok
            assert (await client.hold()).ok
            assert (await client.land()).ok and not vehicle.sim.armed
            assert (await client.start_mission()).ok
            assert (await client.wait_mission(timeout_s=60.0)).ok
            assert (await client.rtl()).ok

    run(go(), timeout_s=120.0)
    assert relay.copied.count("MISSION_ITEM_INT") >= 8 and relay.copied.count("COMMAND_ACK") >= 6


def test_a_stale_mission_ack_does_not_end_a_later_upload(vehicle, relay):
    """The ACCEPTED MISSION_ACK of an upload, copied and delivered just after the next upload's MISSION_COUNT: the
    vehicle has asked for nothing of the new plan yet, so it cannot be the new plan's answer (before: the upload
    returned ``ok`` with nothing sent, and the vehicle, its requests unanswered, kept the old plan)."""
    first, second = plans(vehicle)["mission"][:2], plans(vehicle)["mission"]

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            relay.keep_copy(kind("MISSION_ACK", to_vehicle=False))
            assert (await client.upload_mission(first)).ok
            relay.release_before(kind("MISSION_COUNT", to_vehicle=True))
            up = await client.upload_mission(second)
            assert relay.released == 1
            return up, await client.download_mission()

    up, down = run(go(), timeout_s=60.0)
    assert up.ok, up.reason
    assert stored(vehicle, "mission") == len(second), "reported ok, but the vehicle kept the old plan"
    assert down.ok and all(same_item(a, b) for a, b in zip(second, down.items, strict=True))


def test_a_stale_item_request_beyond_the_plan_does_not_fail_a_later_upload(vehicle, relay):
    """A MISSION_REQUEST_INT for item 3 of a four-item upload, copied and delivered during a two-item upload: it is
    an old request, not the vehicle's (which asks for items in order, each below the count it was sent), so it is
    not answered, as MAVSDK does (before: the upload failed 'the vehicle asked for item 3 of 2')."""
    four = plans(vehicle)["mission"]

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            relay.keep_copy(kind("MISSION_REQUEST_INT", to_vehicle=False, seq=3))
            assert (await client.upload_mission(four)).ok
            relay.release_before(kind("MISSION_COUNT", to_vehicle=True))
            up = await client.upload_mission(four[:2])
            assert relay.released == 1
            return up

    up = run(go(), timeout_s=60.0)
    assert up.ok, up.reason
    assert stored(vehicle, "mission") == 2


CANCEL = kind("MISSION_ACK", to_vehicle=True, type=mavlink2.MAV_MISSION_OPERATION_CANCELLED)


@pytest.mark.parametrize(
    ("before_item", "then"),
    [(2, None), (3, None), (2, "cancel lost"), (2, "cancel late")],
    ids=["mid-upload", "as-the-last-item-goes", "its-cancel-lost", "its-cancel-late"],
)
def test_a_duplicated_count_arriving_mid_upload_is_survived(vehicle, relay, before_item, then):
    """The MISSION_COUNT copied and delivered once the vehicle has asked for an item (the last one, too): the
    vehicle, as PX4, answers it MAV_MISSION_ERROR ('WPM: REJ. CMD: Busy') and goes on with the transfer. The client
    cancels that transfer and uploads again, so the plan is stored (before: the upload ended 'denied' on a refusal
    of a copy the client never sent, and the vehicle, its requests unanswered, kept the old plan; as the last item
    went out, or with the cancel lost (the vehicle still busy) or delivered late into the next try, it still did)."""
    items = plans(vehicle)["mission"]
    assert before_item < len(items)

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            relay.keep_copy(kind("MISSION_COUNT", to_vehicle=True))
            relay.release_before(kind("MISSION_ITEM_INT", to_vehicle=True, seq=before_item))
            if then == "cancel lost":
                relay.lose(CANCEL)
            elif then == "cancel late":  # a copy kept back and delivered in the next try, just before its item 1
                relay.keep_copy(CANCEL)
                relay.releases.append(
                    Rule(lambda m, out: out and m.get_type() == "MISSION_ITEM_INT" and m.seq == 1 and relay.released, 1)
                )
            up = await client.upload_mission(items)
            assert relay.released == (2 if then == "cancel late" else 1)
            return up

    up = run(go(), timeout_s=60.0)
    assert up.ok, up.reason
    assert stored(vehicle, "mission") == len(items)


def test_a_late_copy_of_an_item_request_in_a_download_is_survived(vehicle, relay):
    """The client's request for item 0, copied and delivered once it has asked for item 2: the vehicle, as PX4,
    takes it as a request out of order and ends the download with MAV_MISSION_ERROR ('Req. WP was unexpected').
    The client downloads again, once (before: 'denied' for a plan the vehicle holds and sends)."""
    items = plans(vehicle)["mission"]

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert (await client.upload_mission(items)).ok
            relay.keep_copy(kind("MISSION_REQUEST_INT", to_vehicle=True, seq=0))
            relay.release_before(kind("MISSION_REQUEST_INT", to_vehicle=True, seq=2))
            down = await client.download_mission()
            assert relay.released == 1
            return down

    down = run(go(), timeout_s=60.0)
    assert down.ok, down.reason
    assert all(same_item(a, b) for a, b in zip(items, down.items, strict=True))


def test_a_stale_accepted_ack_never_makes_a_denied_goto_ok(vehicle, relay):
    """COMMAND_ACK carries no sequence number (MAVLink's command protocol), so an ACCEPTED copy of an earlier
    go-to's answer, delivered as the next go-to is sent, cannot be told from the answer to it (MAVSDK and QGC alike
    take it). What the client must not do is report the go-to done: the vehicle, which refused it (past its
    geofence), did not move, and the result says so."""

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            assert await client.set_param("GF_MAX_HOR_DIST", 100.0) == 100.0
            assert (await client.arm()).ok and (await client.takeoff(5.0)).ok
            relay.keep_copy(kind("COMMAND_ACK", to_vehicle=False, command=192, result=0))
            assert (await client.goto(*near_home(vehicle, 6.0, 0.0), 5.0)).ok
            relay.release_before(kind("COMMAND_INT", to_vehicle=True, command=192))
            far = await client.goto(*near_home(vehicle, 300.0, 0.0), 5.0, timeout_s=5.0)
            assert relay.released == 1
            return far

    far = run(go(), timeout_s=60.0)
    assert far.status != "ok" and not far.reached, far
    assert abs(vehicle.sim.state().north_m - 6.0) < 2.0  # the vehicle stayed where the first go-to took it


def test_a_stale_echo_does_not_answer_a_later_set(vehicle, relay):
    """The PARAM_VALUE echo of one set, copied and delivered as the next set of the same parameter goes out: the
    later set waits for its own echo and returns the value the vehicle holds."""

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            relay.keep_copy(kind("PARAM_VALUE", to_vehicle=False))
            assert await client.set_param("MPC_XY_CRUISE", 6.0) == 6.0
            relay.release_before(kind("PARAM_SET", to_vehicle=True))
            value = await client.set_param("MPC_XY_CRUISE", 9.0)
            assert relay.released == 1
            return value

    assert run(go()) == 9.0 == vehicle.params["MPC_XY_CRUISE"]


def test_a_refusal_and_its_reason_swapped_still_give_the_reason(vehicle, relay):
    """The STATUSTEXT that says why goes just after the COMMAND_ACK that refuses (they swapped on the way)."""
    relay.delay(kind("STATUSTEXT", to_vehicle=False))

    async def go() -> Any:
        async with await VehicleClient.connect(relay.address, timeout_s=CONNECT_S, ack_timeout_s=0.5) as client:
            return await client.land()  # on the ground: refused

    refused = run(go())
    assert refused.status == "denied" and refused.reason and "MAV_RESULT" not in refused.reason, refused


def test_with_signing_a_late_copy_of_a_command_is_refused_as_a_replay():
    """Unsigned, the vehicle acts on a late copy of a command again (as PX4: MAVLink has no de-duplication of
    commands); signed, the copy carries the first one's timestamp and is refused as a replay, so a go-to delivered
    again after a later one does not take the vehicle back."""
    key = bytes(range(32))
    v = MavlinkVehicle(Simulator(seed=11), gcs=None, api=None, signing_key=key)
    v.start(speed=FAST_FORWARD)
    lossy = DuplicatingRelay(v.address)

    async def go() -> None:
        async with await VehicleClient.connect(
            lossy.address, timeout_s=5.0, ack_timeout_s=0.5, signing_key=key
        ) as client:
            assert (await client.arm()).ok and (await client.takeoff(5.0)).ok
            lossy.keep_copy(kind("COMMAND_INT", to_vehicle=True, command=192))
            assert (await client.goto(*near_home(v, 8.0, 0.0), 5.0)).ok
            assert (await client.goto(*near_home(v, 0.0, 8.0), 5.0)).ok
            replayed = v.guard.report()["replayed"]
            lossy.release_before(everything)
            await wait_for_async(lambda: lossy.released == 1, 5.0, what="the copy delivered")
            await wait_for_async(lambda: v.guard.report()["replayed"] > replayed, 5.0, what="the copy refused")
            assert math.hypot(v.sim.state().north_m, v.sim.state().east_m - 8.0) < 2.0

    try:
        run(go(), timeout_s=60.0)
    finally:
        lossy.close()
        v.close()
