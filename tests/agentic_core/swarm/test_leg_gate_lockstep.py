"""The leg gate with real simulated F450s on the swarm's lockstep clock: two UAVs take off from pads 120 m apart and
are sent on legs that cross at the same time in the same layer. Without the gate they lose separation over the
crossing; with it, the separation flown (measured on the shared clock as a swarm run does) stays above the
configured minimum, through the aircraft's own accelerations and lags, the second UAV flying in another layer or
later as the airspace decides."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest

from agentic_core.agent.pacing import Pace
from agentic_core.contracts import TelemetrySample
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.swarm import Point
from agentic_core.contracts.swarm_plan import SwarmPlan
from agentic_core.run.swarm_airspace import swarm_airspace
from agentic_core.run.swarm_backend import LockstepBackend
from agentic_core.swarm.leg_gate import gate_legs
from agentic_core.swarm.legs import LegBook
from agentic_core.swarm.separation import SeparationLog
from flight.mavlink.lockstep import Lockstep
from flight.sim.environment import Home
from flight.tools import register_flight_tools
from flight.vehicle import VehicleClient
from tools import ToolContext, ToolRegistry

pytestmark = [pytest.mark.slow, pytest.mark.timeout(300)]

HOME = Home()
H, V = 15.0, 8.0
PADS = {"west": -60.0, "east": 60.0}
GOALS = {"west": (120.0, 60.0), "east": (120.0, -60.0)}
"""Each flies 170 m north-eastwards or north-westwards: the legs cross at (60, 0) at the same moment."""


@dataclass
class Pair:
    calls: dict[str, Any]
    separation: SeparationLog
    records: list[dict[str, Any]]
    where: dict[str, Point]

    def both(self, tool: str, args: dict[str, dict[str, Any]]) -> dict[str, Any]:
        """Call ``tool`` for both UAVs at once (the west one first); each one's result."""
        results: dict[str, Any] = {}
        threads = [threading.Thread(target=lambda n=n: results.update({n: self.calls[n](tool, args[n])})) for n in PADS]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join(timeout=240.0)
        return results


def position(where: dict[str, Point], name: str) -> Callable[[], Point]:
    return lambda: where[name]


@contextmanager
def two_f450s(layers: list[float] | None) -> Iterator[Pair]:
    """Two F450s on one clock, their flight tools gated in an airspace of ``layers`` (None: not gated)."""
    clock = Lockstep()
    backends = {
        name: LockstepBackend(
            clock=clock, index=i, home=HOME, pad_east_m=east, px4_ports=False, seed=i, pace=Pace(None)
        )
        for i, (name, east) in enumerate(PADS.items())
    }
    separation = SeparationLog(horizontal_m=H, vertical_m=V)
    where = {name: Point(north=0.0, east=east) for name, east in PADS.items()}

    def hook(name: str) -> Any:
        def on_sample(sample: TelemetrySample) -> None:
            where[name] = here = Point(north=sample.north_m, east=sample.east_m, alt=sample.alt_m)
            if sample.armed and sample.alt_m > 1.0:
                separation.record(name, sample.time_s, here)

        return on_sample

    records: list[dict[str, Any]] = []
    book = LegBook(
        swarm_airspace(SwarmPlan.model_validate({"area": [{"lat": 0, "lon": 0}] * 3, "layers_m": layers or [30.0]})),
        clock=lambda: clock.time_s, record=lambda event, **fields: records.append({"event": event, **fields}),
    )  # fmt: skip
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, name="test-tools", daemon=True)
    thread.start()
    calls = {}
    for name, backend in backends.items():
        backend.on_sample(hook(name))
        registry = ToolRegistry()

        async def connect(address: tuple[str, int] = backend.address) -> VehicleClient:
            return await VehicleClient.connect(f"{address[0]}:{address[1]}", timeout_s=10.0)

        register_flight_tools(registry, connect)
        if layers is not None:
            book.prefer(name, layers[0])
            gate_legs(registry, book, name, here=position(where, name), origin=(HOME.lat_deg, HOME.lon_deg),
                      pad=Point(north=0.0, east=PADS[name]))  # fmt: skip

        def call(tool: str, args: dict[str, Any], registry: ToolRegistry = registry) -> Any:
            context = ToolContext(call_id=tool, tool=tool, caller=None, attempt=1, deadline=None)  # type: ignore[arg-type]
            work = registry.get(tool).handler(args, context)
            return asyncio.run_coroutine_threadsafe(work, loop).result(timeout=240.0)

        calls[name] = call
    clock.start(None)
    try:
        yield Pair(calls, separation, records, where)
    finally:
        clock.stop()
        loop.call_soon_threadsafe(loop.stop)
        thread.join(timeout=5.0)
        for backend in backends.values():
            backend.close()


def fly_the_crossing(pair: Pair) -> None:
    up = pair.both("flight.takeoff", {n: {"altitude_m": 30.0} for n in PADS})
    assert all(r.status == "ok" for r in up.values()), up
    legs = {}
    for name, (north, east) in GOALS.items():
        lat, lon = offset_position(HOME.lat_deg, HOME.lon_deg, north, east)
        legs[name] = {"lat": lat, "lon": lon, "alt_m": 30.0}
    across = pair.both("flight.fly_to", legs)
    assert all(r.status == "ok" for r in across.values()), across
    for name, (north, east) in GOALS.items():
        assert pair.where[name].horizontal_to(Point(north=north, east=east)) < 3.0  # each got where it was sent


def test_without_the_gate_two_f450s_lose_separation_over_the_crossing() -> None:
    with two_f450s(None) as pair:
        fly_the_crossing(pair)
    report = pair.separation.report()
    assert report["losses"] > 0 and report["min_distance_m"] < H


@pytest.mark.parametrize("layers", [[30.0, 40.0], [30.0]], ids=["two-layers", "one-layer"])
def test_with_the_gate_two_f450s_keep_the_separation_over_the_crossing(layers: list[float]) -> None:
    with two_f450s(layers) as pair:
        fly_the_crossing(pair)
    report = pair.separation.report()
    assert report["instants"] > 200 and report["losses"] == 0
    assert report["min_distance_m"] >= min(H, V)
    crossings = [r for r in pair.records if r["event"] == "leg" and r["tool"] == "flight.fly_to"]
    assert sorted(r["decision"] for r in crossings) == (["granted", "relayered"] if len(layers) > 1 else
                                                         ["delayed", "granted"])  # fmt: skip
    assert not [r for r in pair.records if r.get("decision") == "strayed"]
