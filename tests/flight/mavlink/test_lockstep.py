"""Several vehicles on one clock: they tick together, a closed one drops out without stopping the rest, and each
keeps PX4's multi-vehicle numbering."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from flight.mavlink import MavlinkVehicle
from flight.mavlink.lockstep import Lockstep
from flight.sim import Simulator
from tests.waiting import wait_for


@pytest.fixture
def fleet() -> Iterator[list[MavlinkVehicle]]:
    vehicles = [MavlinkVehicle(Simulator(seed=i), gcs=None, api=None, system_id=i + 1) for i in range(3)]
    yield vehicles
    for vehicle in vehicles:
        vehicle.close()


def test_every_vehicle_keeps_the_one_clock(fleet: list[MavlinkVehicle]) -> None:
    clock = Lockstep(fleet)
    clock.run_for(1.0)
    times = {round(v.sim.time_s, 6) for v in fleet}
    assert times == {1.0}
    assert clock.time_s == pytest.approx(1.0)


def test_the_clock_thread_ticks_them_together_at_full_speed(fleet: list[MavlinkVehicle]) -> None:
    clock = Lockstep(fleet)
    clock.start(None)
    try:
        wait_for(lambda: clock.time_s >= 2.0, timeout_s=30.0, what="2 simulated seconds")
    finally:
        clock.stop()
    assert len({v.sim.time_s for v in fleet}) == 1  # stopped between rounds: no vehicle a tick ahead


def test_a_closed_vehicle_drops_out_and_the_others_fly_on(fleet: list[MavlinkVehicle]) -> None:
    clock = Lockstep(fleet)
    clock.start(None)
    try:
        wait_for(lambda: clock.time_s >= 0.5, timeout_s=30.0)
        fleet[1].close()  # a UAV killed mid-flight
        stopped_at = fleet[1].sim.time_s
        wait_for(lambda: clock.time_s >= stopped_at + 1.0, timeout_s=30.0, what="the survivors flying on")
    finally:
        clock.stop()
    assert fleet[1] not in clock.vehicles
    assert fleet[1].sim.time_s == stopped_at
    assert fleet[0].sim.time_s == fleet[2].sim.time_s > stopped_at + 1.0
    assert any("system 2 dropped out" in e for e in clock.errors)


def test_a_bad_speed_is_refused_in_the_callers_thread(fleet: list[MavlinkVehicle]) -> None:
    with pytest.raises(ValueError, match="positive"):
        Lockstep(fleet).start(-2.0)


def test_px4_numbering_system_ids_and_api_ports() -> None:
    from agentic_core.agent.pacing import Pace
    from agentic_core.run.swarm_backend import API_PORT, LockstepBackend
    from flight.sim.environment import Home

    clock = Lockstep()
    backends = [
        LockstepBackend(clock=clock, index=i, home=Home(), pad_east_m=20.0 * i, px4_ports=True, seed=i, pace=Pace(None))
        for i in range(3)
    ]
    try:
        assert [b.vehicle.system_id for b in backends] == [1, 2, 3]
        assert [("127.0.0.1", API_PORT + i) in b.vehicle._targets for i, b in enumerate(backends)] == [True] * 3
        assert clock.vehicles == [b.vehicle for b in backends]
        assert backends[0].sim.environment.home.lon_deg < backends[2].sim.environment.home.lon_deg  # pads eastwards
    finally:
        for backend in backends:
            backend.close()
    assert not any(b.alive for b in backends)
