"""Shared helpers for the simulator tests."""

import math

import pytest

from flight.sim import Simulator


def dist_to(state, target):
    return math.dist((state.north_m, state.east_m, state.down_m), target)


@pytest.fixture
def hovering_sim():
    """A simulator armed, taken off to 10 m above home and settled there (about 10 s of simulated time)."""
    sim = Simulator(seed=7)
    assert sim.arm()
    assert sim.takeoff(10.0)
    assert sim.run_until(lambda s: abs(s.down_m + 10.0) < 0.2, timeout_s=15.0)
    sim.run_for(3.0)
    return sim
