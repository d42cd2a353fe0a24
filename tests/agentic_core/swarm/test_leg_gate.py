"""The airspace governs the legs the UAVs fly: two UAVs sent across each other in one layer at one time lose
separation without the gate, and with it the separation flown (``swarm/separation.py``) stays above the configured
minimum — the second leg flown in another layer, or later, as the airspace decides, each decision a line of the
swarm's log. A dead UAV's reservations are released; a leg refused for good is a tool error; a path the airspace
cannot reserve is refused. Vehicles here are kinematic fakes on a fake clock ticking in its own thread."""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import pytest

from agentic_core.contracts.geodesy import local_offset, offset_position
from agentic_core.contracts.swarm import Point
from agentic_core.swarm.coordinator import SwarmCoordinator
from agentic_core.swarm.deconflict import Airspace, NoSafeLeg
from agentic_core.swarm.leg_gate import gate_legs
from agentic_core.swarm.legs import LegBook
from agentic_core.swarm.separation import GRID_S, SeparationLog
from agentic_core.swarm.signing import SwarmKey
from tests.agentic_core.swarm.test_coordinator import Uav
from tests.waiting import wait_for
from tools import ToolContext, ToolError, ToolRegistry
from tools.function import spec_from_function

ORIGIN = (21.4133, 39.8933)
H, V = 15.0, 8.0
SPEED, CLIMB = 5.0, 2.5


@dataclass
class Aircraft:
    """A point that flies at a fixed speed towards its target, horizontally and vertically at once."""

    name: str
    at: Point
    target: Point | None = None
    speed: float = SPEED
    track: list[Point] = field(default_factory=list)

    def step(self, dt: float) -> None:
        if self.target is None:
            return
        dn, de = self.target.north - self.at.north, self.target.east - self.at.east
        dz = self.target.alt - self.at.alt
        far = math.hypot(dn, de)
        f = 1.0 if far <= self.speed * dt else self.speed * dt / far
        climb = max(-CLIMB * dt, min(CLIMB * dt, dz))
        self.at = Point(north=self.at.north + f * dn, east=self.at.east + f * de, alt=self.at.alt + climb)
        self.track.append(self.at)

    def where(self) -> Point:
        return self.at

    def arrived(self) -> bool:
        return self.target is None or self.at.distance_to(self.target) < 0.01


class Sky:
    """A fake clock ticking every aircraft ``GRID_S`` at a time (pausing ``pause_s`` between), recording separation."""

    def __init__(self, *aircraft: Aircraft, pause_s: float = 0.001) -> None:
        self.pause_s = pause_s
        self.aircraft = {a.name: a for a in aircraft}
        self.ticks = 0
        self.separation = SeparationLog(horizontal_m=H, vertical_m=V)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="test-sky", daemon=True)

    def now(self) -> float:
        return self.ticks * GRID_S

    def _run(self) -> None:
        while not self._stop.is_set():
            for a in self.aircraft.values():
                a.step(GRID_S)
            self.ticks += 1
            for a in self.aircraft.values():
                if a.at.alt > 1.0:
                    self.separation.record(a.name, self.now(), a.at)
            time.sleep(self.pause_s)

    def __enter__(self) -> Sky:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)


def fake_flight_tools(registry: ToolRegistry, sky: Sky, aircraft: Aircraft) -> None:
    """``flight.*`` with the real tools' names and arguments, moving ``aircraft`` and returning when it arrives."""

    async def go(target: Point, speed: float | None = None) -> dict[str, Any]:
        aircraft.target, aircraft.speed = target, speed or SPEED
        while not aircraft.arrived():
            await asyncio.sleep(0.001)
        return {"status": "ok", "at": aircraft.at.model_dump()}

    def place(lat: float, lon: float, alt: float) -> Point:
        north, east = local_offset(*ORIGIN, lat, lon)
        return Point(north=north, east=east, alt=alt)

    async def fly_to(lat: float, lon: float, alt_m: float | None = None, speed_mps: float | None = None) -> Any:
        return await go(place(lat, lon, aircraft.at.alt if alt_m is None else alt_m), speed_mps)

    async def takeoff(altitude_m: float = 10.0) -> Any:
        return await go(aircraft.at.model_copy(update={"alt": altitude_m}))

    async def land(lat: float | None = None, lon: float | None = None) -> Any:
        where = aircraft.at if lat is None or lon is None else place(lat, lon, aircraft.at.alt)
        await go(where)
        return await go(where.model_copy(update={"alt": 0.0}))

    async def hover(duration_s: float) -> Any:
        end = sky.now() + duration_s
        while sky.now() < end:
            await asyncio.sleep(0.001)
        return {"status": "ok"}

    async def orbit(radius_m: float) -> Any:
        return {"status": "ok"}

    async def rtl() -> Any:
        return await go(aircraft.at.model_copy(update={"alt": 60.0}))  # the autopilot's own return: up first

    async def hold() -> Any:
        aircraft.target = None
        return {"status": "ok"}

    for fn in (fly_to, takeoff, land, hover, orbit, rtl, hold):
        registry.register(spec_from_function(fn, name=f"flight.{fn.__name__}"))


def latlon(north: float, east: float) -> dict[str, float]:
    lat, lon = offset_position(*ORIGIN, north, east)
    return {"lat": lat, "lon": lon}


def call(registry: ToolRegistry, tool: str, args: dict[str, Any]) -> Any:
    context = ToolContext(call_id=tool, tool=tool, caller=None, attempt=1, deadline=None)  # type: ignore[arg-type]
    result = registry.get(tool).handler(args, context)
    return asyncio.run(result) if asyncio.iscoroutine(result) else result


@dataclass
class Crossing:
    """Two UAVs in layer 30, one 100 m west of the crossing point, one 100 m south, each sent across it."""

    sky: Sky
    registries: dict[str, ToolRegistry]
    records: list[dict[str, Any]]
    book: LegBook

    def fly(self, first_uav_moving: bool = True) -> dict[str, Any]:
        results: dict[str, Any] = {}
        legs = {"east": latlon(0.0, 100.0), "north": latlon(100.0, 0.0)}

        def one(name: str) -> None:
            try:
                results[name] = call(self.registries[name], "flight.fly_to", {**legs[name], "alt_m": 30.0})
            except Exception as exc:  # the test reads it
                results[name] = exc

        threads = [threading.Thread(target=one, args=(n,), name=f"test-{n}") for n in legs]
        threads[0].start()
        if first_uav_moving:  # the second asks while the first is on its way
            wait_for(lambda: self.sky.aircraft["east"].target is not None, 10.0, what="the first leg flying")
        threads[1].start()
        for thread in threads:
            thread.join(timeout=60.0)
        assert not any(t.is_alive() for t in threads)
        return results


@contextmanager
def crossing(
    layers: tuple[float, ...], *, gated: bool, patience_s: float = 300.0, pause_s: float = 0.001
) -> Iterator[Crossing]:
    east = Aircraft("east", Point(north=0.0, east=-100.0, alt=30.0))
    north = Aircraft("north", Point(north=-100.0, east=0.0, alt=30.0))
    records: list[dict[str, Any]] = []
    with Sky(east, north, pause_s=pause_s) as sky:
        book = LegBook(
            Airspace(layers=layers, horizontal_m=H + 3.0, vertical_m=V, speed_mps=SPEED, climb_mps=CLIMB, hold_s=1e5),
            clock=sky.now, record=lambda event, **fields: records.append({"event": event, **fields}),
        )  # fmt: skip
        registries = {}
        for a in (east, north):
            registries[a.name] = registry = ToolRegistry()
            fake_flight_tools(registry, sky, a)
            if gated:
                book.prefer(a.name, layers[0])
                gate_legs(registry, book, a.name, here=a.where, origin=ORIGIN, pad=Point(north=0, east=0),
                          poll_s=0.001, patience_s=patience_s)  # fmt: skip
        yield Crossing(sky, registries, records, book)


@pytest.fixture(params=[(30.0, 40.0), (30.0,)], ids=["two-layers", "one-layer"])
def gated(request: pytest.FixtureRequest) -> Iterator[Crossing]:
    with crossing(request.param, gated=True) as situation:
        yield situation


def test_without_the_gate_crossing_legs_in_one_layer_lose_separation() -> None:
    with crossing((30.0,), gated=False) as situation:  # the same situation, the flight tools called as they are
        situation.fly()
    report = situation.sky.separation.report()
    assert report["losses"] > 0 and report["min_distance_m"] < H


def test_with_the_gate_the_separation_flown_stays_above_the_minimum(gated: Crossing) -> None:
    results = gated.fly()
    assert all(r["status"] == "ok" for r in results.values()), results
    report = gated.sky.separation.report()
    assert report["instants"] > 100  # both were in the air together, for a while
    assert report["losses"] == 0
    assert report["min_distance_m"] >= min(H, V)
    legs = [r for r in gated.records if r["event"] == "leg"]
    assert [r["uav"] for r in legs] == ["east", "north"] and legs[0]["decision"] == "granted"
    if len(gated.book.airspace.layers) > 1:  # another layer is free: the second UAV crosses there, and flies there
        assert legs[1]["decision"] == "relayered" and legs[1]["layer_m"] == 40.0 and legs[1]["delay_s"] == 0
        assert gated.sky.aircraft["north"].at.alt == pytest.approx(40.0, abs=0.01)
    else:  # no other layer: it holds where it is until the crossing is clear
        assert legs[1]["decision"] == "delayed" and legs[1]["delay_s"] > 0 and legs[1]["layer_m"] == 30.0
    for leg in legs:
        goal = Point(north=leg["goal"][0], east=leg["goal"][1])
        assert gated.sky.aircraft[leg["uav"]].at.horizontal_to(goal) < 0.5  # it got where it was sent


def test_a_leg_refused_for_good_is_a_tool_error_and_each_refusal_is_logged() -> None:
    with crossing((30.0,), gated=True, patience_s=20.0) as situation:
        situation.book.airspace.max_delay_s = 10.0
        call(situation.registries["east"], "flight.fly_to", {**latlon(0.0, 0.0), "alt_m": 30.0})  # parks for good
        with pytest.raises(ToolError, match="refused the leg for 20 s"):
            call(situation.registries["north"], "flight.fly_to", {**latlon(100.0, 0.0), "alt_m": 30.0})
    refused = [r for r in situation.records if r.get("decision") == "refused"]
    assert len(refused) >= 2 and {r["uav"] for r in refused} == {"north"}
    assert situation.sky.aircraft["north"].at == Point(north=-100.0, east=0.0, alt=30.0)  # it never moved


def test_a_hold_supersedes_a_leg_waiting_for_its_start_and_takes_its_place_in_the_airspace() -> None:
    with crossing((30.0,), gated=True, pause_s=0.005) as situation:  # 20 times real time: a second to stop it
        north = situation.registries["north"]
        outcome: list[Any] = []

        def delayed_leg() -> None:
            try:
                outcome.append(call(north, "flight.fly_to", {**latlon(100.0, 0.0), "alt_m": 30.0}))
            except ToolError as exc:
                outcome.append(exc)

        east = threading.Thread(
            target=call, args=(situation.registries["east"], "flight.fly_to", {**latlon(0.0, 100.0), "alt_m": 30.0})
        )
        east.start()
        wait_for(lambda: situation.records, 10.0, what="the first leg granted")
        waiting = threading.Thread(target=delayed_leg)
        waiting.start()
        wait_for(lambda: len(situation.records) > 1, 10.0, what="the second leg delayed")
        assert situation.records[1]["decision"] == "delayed"
        call(north, "flight.hold", {})  # the agent stops it while it waits for its start
        waiting.join(timeout=10.0)
        east.join(timeout=60.0)
    (error,) = outcome
    assert isinstance(error, ToolError) and "superseded by flight.hold" in str(error)
    assert situation.sky.aircraft["north"].at == Point(north=-100.0, east=0.0, alt=30.0)  # it never left
    last = situation.book.airspace.reserved["north"][-1]
    assert last.waypoints == ((last.start, Point(north=-100.0, east=0.0, alt=30.0)),)  # a hold, not the dropped leg


def test_a_uav_the_swarm_has_lost_gives_up_the_command_under_way_and_flies_no_more() -> None:
    with crossing((30.0,), gated=True, pause_s=0.005) as situation:
        east = situation.registries["east"]
        outcome: list[Any] = []

        def long_leg() -> None:
            try:
                outcome.append(call(east, "flight.fly_to", {**latlon(0.0, 400.0), "alt_m": 30.0}))  # 100 s of flight
            except ToolError as exc:
                outcome.append(exc)

        flying = threading.Thread(target=long_leg)
        flying.start()
        wait_for(lambda: situation.sky.aircraft["east"].target is not None, 10.0, what="the leg under way")
        situation.book.release("east", "its vehicle stopped answering", lost=True)  # what the coordinator does
        flying.join(timeout=5.0)  # not the 5 s of wall the rest of the leg would take at this pace
        assert not flying.is_alive()
        with pytest.raises(ToolError, match="east is lost"):
            call(east, "flight.fly_to", {**latlon(0.0, 0.0), "alt_m": 30.0})
    (error,) = outcome
    assert isinstance(error, ToolError) and "given up: east is lost to the swarm" in str(error)
    assert "east" not in situation.book.airspace.reserved  # nothing of a lost UAV is reserved again


def test_a_path_the_airspace_cannot_reserve_is_refused_and_the_way_home_stays_in_the_layer() -> None:
    with crossing((30.0, 40.0), gated=True) as situation:
        with pytest.raises(ToolError, match="cannot reserve"):
            call(situation.registries["east"], "flight.orbit", {"radius_m": 20.0})
        call(situation.registries["east"], "flight.rtl", {})
        highest = max((p.alt for p in situation.sky.aircraft["east"].track), default=0.0)
    east = situation.sky.aircraft["east"]
    assert east.at.alt == pytest.approx(0.0, abs=0.01) and east.at.horizontal_to(Point(north=0, east=0)) < 0.5
    assert highest <= 30.0 + 0.01  # home in its layer, never up through the others as the autopilot's return goes
    assert situation.book.airspace.reserved.get("east") is None  # landed at home: its reservations released
    assert [r["decision"] for r in situation.records if r["uav"] == "east"] == ["granted", "released"]


def test_a_dead_uavs_reservations_are_released_and_its_airspace_given_to_others() -> None:
    uavs = [Uav("uav-1", -10.0), Uav("uav-2", 10.0)]
    records: list[dict[str, Any]] = []
    swarm = SwarmCoordinator(
        SwarmKey.generate("mina"), [u.member(30.0) for u in uavs], [], log=records.append,
        airspace=Airspace(layers=(30.0,), horizontal_m=H, vertical_m=V, hold_s=1e5, max_delay_s=20.0),
    )  # fmt: skip
    try:
        parked = Point(north=50.0, east=0.0, alt=30.0)
        swarm.legs.request("uav-1", Point(north=0, east=-10, alt=30), parked, tool="flight.fly_to")
        across = {"start": Point(north=50, east=-100, alt=30), "goal": Point(north=50, east=100), "tool": "t"}
        with pytest.raises(NoSafeLeg, match="no layer"):
            swarm.legs.request("uav-2", **across)  # type: ignore[arg-type]
        uavs[0].alive = False
        swarm.watch()
        swarm.legs.hold("uav-1", parked)  # a dead UAV's agent, still holding where its aircraft was
        swarm.watch()  # released once, and for good
        assert "uav-1" not in swarm.legs.airspace.reserved
        released = [r for r in records if r["event"] == "airspace_released"]
        assert [(r["uav"], r["legs"]) for r in released] == [("uav-1", 1)]
        grant = swarm.legs.request("uav-2", **across)  # type: ignore[arg-type]
        assert grant.delay_s == 0 and grant.layer_m == 30.0
        with pytest.raises(NoSafeLeg, match="uav-1 is lost"):
            swarm.legs.request("uav-1", Point(north=0, east=-10, alt=30), parked, tool="flight.fly_to")
        assert "uav-1" not in swarm.legs.airspace.reserved
        swarm.legs.request("uav-2", Point(north=50, east=100, alt=30), parked, tool="flight.fly_to")
        swarm.fail("uav-2", "its vehicle stopped answering")  # a failure releases too
        assert swarm.legs.airspace.reserved == {} and swarm.legs.lost == {"uav-1", "uav-2"}
    finally:
        swarm.close()
