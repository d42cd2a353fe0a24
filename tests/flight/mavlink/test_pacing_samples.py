"""The vehicle's pace (a callable asked every tick) and the TelemetrySamples it hands its hooks in lockstep."""

import itertools
import math
import threading
import time

import pytest
from pymavlink import mavutil

from agentic_core.contracts.telemetry import TelemetrySample
from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator

from .conftest import take_off

m = mavutil.mavlink


def wait_for(cond, timeout_s):
    """Poll ``cond`` until true; False after ``timeout_s`` of wall time."""
    end = time.monotonic() + timeout_s
    pause = threading.Event()
    while time.monotonic() < end:
        if cond():
            return True
        pause.wait(0.01)
    return cond()


def sim_rate_over(vehicle, wall_s):
    """Simulated seconds per wall second, measured over ``wall_s`` of wall time."""
    t0_wall, t0_sim = time.monotonic(), vehicle.sim.time_s
    wait_for(lambda: time.monotonic() - t0_wall >= wall_s, wall_s + 1.0)
    return (vehicle.sim.time_s - t0_sim) / (time.monotonic() - t0_wall)


class Pace:
    """A pace the test switches, counting how often the vehicle asks."""

    def __init__(self, answer):
        self.answer = answer
        self.asked = 0

    def __call__(self):
        self.asked += 1
        return self.answer


def test_a_pace_switches_between_fast_and_real_time_without_a_burst():
    pace = Pace(None)
    with MavlinkVehicle(Simulator(seed=1), gcs=None, api=None) as vehicle:
        vehicle.start(pace)
        assert wait_for(lambda: vehicle.sim.time_s > 3.0, 10.0)  # fast: seconds of flight in a moment
        pace.answer = 1.0
        asked = pace.asked
        assert wait_for(lambda: pace.asked > asked + 1, 2.0)
        # Right after the switch: no catch-up (and, the other way, no stall while wall time "catches up").
        start_sim, start_wall = vehicle.sim.time_s, time.monotonic()
        assert wait_for(lambda: vehicle.sim.time_s - start_sim >= 0.1, 2.0), "stalled after switching to real time"
        assert vehicle.sim.time_s - start_sim < (time.monotonic() - start_wall) + 0.3
        assert 0.7 < sim_rate_over(vehicle, 1.0) < 1.3
        pace.answer = 0.5
        asked = pace.asked
        assert wait_for(lambda: pace.asked > asked + 1, 2.0)
        assert 0.3 < sim_rate_over(vehicle, 1.0) < 0.7
        pace.answer = None
        assert sim_rate_over(vehicle, 0.5) > 3.0  # as fast as possible again
        assert list(vehicle.tick_errors) == []


def test_a_pace_that_raises_or_talks_nonsense_is_recorded_and_the_last_good_answer_kept():
    answers = iter([1.0, 1.0])

    def pace():
        answer = next(answers, "soon")
        if answer == "soon":
            raise RuntimeError("pace broke")
        return answer

    with MavlinkVehicle(Simulator(seed=1), gcs=None, api=None) as vehicle:
        vehicle.start(pace)
        assert wait_for(lambda: len(vehicle.tick_errors) >= 3, 5.0)
        assert "pace broke" in vehicle.tick_errors[0]
        assert 0.6 < sim_rate_over(vehicle, 0.6) < 1.4  # still real time, the last good answer
        vehicle.stop()
        vehicle.tick_errors.clear()
        vehicle.start(lambda: -2.0)
        assert wait_for(lambda: len(vehicle.tick_errors) >= 1, 5.0)
        assert "positive or None" in vehicle.tick_errors[0]
        assert 0.5 < sim_rate_over(vehicle, 0.6) < 1.5  # a pace never answering well: real time
    with pytest.raises(ValueError):
        MavlinkVehicle(Simulator(seed=1), gcs=None, api=None).start(-1.0)


def test_samples_are_what_the_wire_says_on_the_vehicle_clock(link):
    samples: dict[int, TelemetrySample] = {}
    link.vehicle.on_telemetry.append(lambda s: samples.setdefault(round(s.time_s * 1000), s))
    take_off(link, 8.0)
    link.vehicle.navigator.reposition(20.0, 10.0, -8.0, None, 5.0)
    link.drain()
    seen = {"GLOBAL_POSITION_INT": 0, "LOCAL_POSITION_NED": 0, "ATTITUDE": 0}
    for _ in range(round(3.0 / link.vehicle.tick_s)):
        link.step()
        while (msg := link.client.recv_match(blocking=False)) is not None:
            kind = msg.get_type()
            if kind not in seen:
                continue
            s = samples[msg.time_boot_ms]
            assert isinstance(s, TelemetrySample)
            seen[kind] += 1
            if kind == "GLOBAL_POSITION_INT":
                assert abs(s.lat_deg - msg.lat / 1e7) < 1e-7 and abs(s.lon_deg - msg.lon / 1e7) < 1e-7
                assert abs(s.alt_m - msg.relative_alt / 1000) < 1e-3 and abs(s.alt_msl_m - msg.alt / 1000) < 1e-3
                assert abs(s.vn_mps - msg.vx / 100) <= 0.006 and abs(s.ve_mps - msg.vy / 100) <= 0.006
                gap = abs(s.yaw_deg - msg.hdg / 100) % 360
                assert min(gap, 360 - gap) < 0.01
            elif kind == "LOCAL_POSITION_NED":
                assert (s.north_m, s.east_m, s.down_m) == pytest.approx((msg.x, msg.y, msg.z), abs=1e-4)
            else:
                assert s.roll_deg == pytest.approx(math.degrees(msg.roll), abs=1e-4)
                assert s.pitch_deg == pytest.approx(math.degrees(msg.pitch), abs=1e-4)
    assert min(seen.values()) >= 10
    last = samples[max(samples)]
    assert last.time_s == pytest.approx(link.vehicle.sim.time_s)
    assert last.mode == "hold" and last.armed and last.landed_state == "in_air"
    assert last.battery_pct == pytest.approx(link.vehicle.sim.battery.percent)
    assert math.hypot(last.vn_mps, last.ve_mps) > 1.0  # flying the leg


def test_one_sample_per_tick_and_none_built_without_a_hook(monkeypatch):
    with MavlinkVehicle(Simulator(seed=2), gcs=None, api=None) as vehicle:
        built: list[float] = []
        real = vehicle.telemetry_sample

        def counted():
            built.append(vehicle.sim.time_s)
            return real()

        monkeypatch.setattr(vehicle, "telemetry_sample", counted)
        vehicle.run_for(1.0)
        assert built == []
        times = []
        vehicle.on_telemetry.append(lambda s: times.append(s.time_s))
        vehicle.run_for(1.0)
        assert len(built) == len(times) == round(1.0 / vehicle.tick_s)
        assert all(b - a == pytest.approx(vehicle.tick_s) for a, b in itertools.pairwise(times))


def test_a_hook_that_raises_is_recorded_and_the_others_and_the_flight_go_on(link):
    got: list[TelemetrySample] = []

    def broken(sample):
        raise KeyError("camera gone")

    link.vehicle.on_telemetry.extend([broken, got.append])
    take_off(link, 5.0)
    assert got and got[-1].alt_m > 4.0
    assert len(link.vehicle.tick_errors) > 10 and "camera gone" in link.vehicle.tick_errors[-1]
    assert "broken" in link.vehicle.tick_errors[-1]
