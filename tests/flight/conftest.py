"""The vehicle the client tests fly (``test_client``, ``test_client_safety``)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator

FAST_FORWARD = 50.0
"""Fifty times real time: minutes of flight in seconds, yet the vehicle thread sleeps between ticks, so on a
loaded 2-core machine the client's threads are not starved (``speed=None`` would spin a core flat out)."""


@pytest.fixture
def vehicle_seed() -> int:
    """The seed of the simulated vehicle's wind gusts and GPS noise; a test module's own fixture overrides it."""
    return 5


@pytest.fixture
def vehicle(vehicle_seed: int) -> Iterator[MavlinkVehicle]:
    """The vehicle ticking fast, sending only to clients that talk to it, with every failsafe on: running free, it
    judges link loss on the wall clock, so the client's 1 Hz heartbeat keeps the link alive however fast simulated
    time runs (a return home mid-test would fail these flights). A test module chooses its seed with its own
    ``vehicle_seed``, or overrides ``vehicle`` itself."""
    v = MavlinkVehicle(Simulator(seed=vehicle_seed), gcs=None, api=None)
    v.start(speed=FAST_FORWARD)
    try:
        yield v
    finally:
        v.close()
