"""Snapshots: a vehicle saved to JSON and restored into a fresh Simulator + MavlinkVehicle carries on its flight."""

import json
import math

import pytest
from pymavlink import mavutil

from agentic_core.contracts.telemetry import TelemetrySample
from flight.mavlink import FlightMode, MavlinkVehicle, VehicleSnapshot
from flight.sim import Environment, Home, SimSnapshot, Simulator, SnapshotError, WindSettings

m = mavutil.mavlink


def mode_of(vehicle):
    """The vehicle's mode (through a function, so that type checkers do not narrow it across steps)."""
    return vehicle.mode


def fresh_vehicle(seed=11, **sim_kwargs):
    return MavlinkVehicle(Simulator(seed=seed, **sim_kwargs), gcs=None, api=None)


def round_trip(vehicle):
    """The snapshot through JSON text into a brand-new vehicle (a different seed and home: the snapshot wins)."""
    text = vehicle.snapshot().model_dump_json()
    other = fresh_vehicle(seed=99, environment=Environment(home=Home(48.0, 11.0, 500.0)))
    other.restore(VehicleSnapshot.from_json(text))
    return other


def take_off(vehicle, alt_m):
    vehicle.navigator.arm()
    vehicle.navigator.takeoff(alt_m)
    for _ in range(round(40.0 / vehicle.tick_s)):
        vehicle.step()
        if vehicle.mode is FlightMode.HOLD:
            return
    raise AssertionError("take-off did not finish")


def test_a_hover_at_15_m_resumes_and_holds_within_a_metre():
    v = fresh_vehicle(environment=Environment(wind=WindSettings(east_mps=3.0, gust_std_mps=0.8)))
    take_off(v, 15.0)
    v.run_for(5.0)
    before = v.sim.state()
    restored = round_trip(v)
    after = restored.sim.state()
    assert after.time_s == before.time_s and after.battery_pct == pytest.approx(before.battery_pct)
    assert restored.sim.environment.home == v.sim.environment.home and restored.sim.wind == v.sim.wind
    assert restored.mode is FlightMode.HOLD and restored.sim.armed and not after.landed
    worst_h = worst_v = 0.0
    for _ in range(round(10.0 / restored.tick_s)):
        restored.step()
        s = restored.sim.state()
        worst_h = max(worst_h, math.hypot(s.north_m - before.north_m, s.east_m - before.east_m))
        worst_v = max(worst_v, abs(s.down_m - before.down_m))
    assert worst_h < 1.0 and worst_v < 1.0, (worst_h, worst_v)
    assert restored.sim.time_s == pytest.approx(before.time_s + 10.0)
    assert restored.sim.state().battery_pct < before.battery_pct  # drains on from the snapshot's charge
    v.close()
    restored.close()


def test_a_vehicle_flying_a_long_leg_at_8_mps_continues_to_its_target_and_arrives():
    v = fresh_vehicle()
    take_off(v, 10.0)
    target = (300.0, -150.0, -10.0)
    v.navigator.reposition(*target, None, 8.0)
    for _ in range(round(15.0 / v.tick_s)):
        v.step()
    moving = v.sim.state()
    assert moving.groundspeed_mps > 7.0 and math.dist((moving.north_m, moving.east_m), target[:2]) > 100.0
    restored = round_trip(v)
    s = restored.sim.state()
    assert s.groundspeed_mps == pytest.approx(moving.groundspeed_mps, abs=0.05)
    assert restored.navigator._goto is not None and restored.navigator.cruise_speed_mps == 8.0
    restored.step()
    assert restored.sim.state().groundspeed_mps > 7.0  # no stop on resuming
    for _ in range(round(60.0 / restored.tick_s)):
        restored.step()
        s = restored.sim.state()
        if math.dist((s.north_m, s.east_m, s.down_m), target) < 1.0 and s.groundspeed_mps < 0.3:
            break
    assert math.dist((s.north_m, s.east_m, s.down_m), target) < 1.0, s
    v.close()
    restored.close()


def test_a_landed_disarmed_vehicle_restores_landed_and_disarmed_with_its_clock_battery_and_payload():
    v = fresh_vehicle()
    take_off(v, 6.0)
    assert v.sim.release_payload()
    v.navigator.land()
    for _ in range(round(30.0 / v.tick_s)):
        v.step()
        if not v.sim.armed:
            break
    v.run_for(2.0)
    before = v.sim.state()
    assert before.landed and not before.armed and before.battery_pct < 100.0
    restored = round_trip(v)
    restored.run_for(3.0)
    after = restored.sim.state()
    assert after.landed and not after.armed and after.payload_released
    assert after.time_s == pytest.approx(before.time_s + 3.0)
    assert after.battery_pct == pytest.approx(before.battery_pct, abs=0.05)  # avionics only: not full, not empty
    assert math.hypot(after.north_m - before.north_m, after.east_m - before.east_m) < 0.05
    assert not restored.sim.release_payload()  # already released
    sample: list[TelemetrySample] = []
    restored.on_telemetry.append(sample.append)
    restored.step()
    assert sample[0].landed_state == "on_ground" and not sample[0].armed
    v.close()
    restored.close()


def test_mode_params_and_stream_rates_come_back():
    v = fresh_vehicle()
    assert v.params.set("RTL_RETURN_ALT", 42.0) and v.set_message_interval(30, 1e6 / 30)
    v.navigator.arm()
    v.navigator.takeoff(20.0)
    v.run_for(2.0)  # still climbing: Takeoff in progress
    restored = round_trip(v)
    assert mode_of(restored) is FlightMode.TAKEOFF and restored.params["RTL_RETURN_ALT"] == 42.0
    assert restored.message_rate_hz(30) == pytest.approx(30.0)
    for _ in range(round(30.0 / restored.tick_s)):
        restored.step()
        if mode_of(restored) is FlightMode.HOLD:
            break
    assert mode_of(restored) is FlightMode.HOLD and abs(restored.sim.state().alt_agl_m - 20.0) < 0.6
    v.close()
    restored.close()


def test_the_simulator_alone_draws_the_same_gusts_and_gps_errors_and_flies_on_close_to_the_original():
    sim = Simulator(seed=4, environment=Environment(wind=WindSettings(north_mps=2.0, gust_std_mps=1.0)))
    sim.run_for(1.3)
    copy = Simulator.from_snapshot(SimSnapshot.from_json(sim.snapshot().model_dump_json()))
    sim.run_for(2.0)
    copy.run_for(2.0)
    assert copy.gps.position_error == sim.gps.position_error  # the random streams carry on where they were
    assert copy.gps.velocity_error == sim.gps.velocity_error and copy.wind == sim.wind
    fa, fb = sim.gps_fix(), copy.gps_fix()
    assert abs(fa.lat_deg - fb.lat_deg) < 1e-7 and abs(fa.lon_deg - fb.lon_deg) < 1e-7  # JSBSim's gear: sub-millimetre
    assert sim.arm() and sim.takeoff(12.0)
    sim.run_for(6.0)
    copy = Simulator.from_snapshot(sim.snapshot())
    sim.run_for(5.0)
    copy.run_for(5.0)
    a, b = sim.state(), copy.state()
    assert math.dist((a.north_m, a.east_m, a.down_m), (b.north_m, b.east_m, b.down_m)) < 0.3
    assert b.battery_pct == pytest.approx(a.battery_pct, abs=0.01) and b.time_s == a.time_s


@pytest.mark.parametrize(
    ("path", "value", "named"),
    [
        (("sim", "battery", "used_mah"), -5.0, "sim.battery.used_mah"),
        (("sim", "battery", "used_mah"), 1e9, "exceeds the capacity"),
        (("sim", "airframe", "alt_agl_m"), -3.0, "sim.airframe.alt_agl_m"),
        (("sim", "airframe", "lat_deg"), "north", "sim.airframe.lat_deg"),
        (("sim", "time_s"), 1.0001, "whole number"),
        (("sim", "controller", "setpoint", "kind"), "Loop", "sim.controller.setpoint.kind"),
        (("sim", "environment", "home", "lat_deg"), 123.0, "home position out of range"),
        (("navigator", "mode"), "ACRO", "navigator.mode"),
        (("params", "RTL_RETURN_ALT"), 1e6, "params.RTL_RETURN_ALT"),
        (("params", "NO_SUCH_PARAM"), 1.0, "params.NO_SUCH_PARAM"),
        (("sim", "surprise"), 1, "sim.surprise"),
        (("sim", "weather", "gps_stream", "generator", "state"), {"state": "x"}, "sim.weather.gps_stream"),
        (("sim", "weather", "gust_stream", "generator", "bit_generator"), "Dice", "unknown bit generator"),
    ],
)
def test_a_bad_field_is_named_and_nothing_changes(path, value, named):
    v = fresh_vehicle()
    v.run_for(0.5)
    data = json.loads(v.snapshot().model_dump_json())
    node = data
    for key in path[:-1]:
        node = node[key]
    node[path[-1]] = value
    target = fresh_vehicle(seed=5)
    target.run_for(1.0)
    with pytest.raises(SnapshotError) as caught:
        target.restore(VehicleSnapshot.from_json(json.dumps(data)))
        # a snapshot built without validation must be refused at restore too
    assert named in str(caught.value) and "Traceback" not in str(caught.value)
    assert target.sim.time_s == pytest.approx(1.0)  # untouched
    v.close()
    target.close()


def test_a_snapshot_built_without_validation_is_refused_at_restore():
    v = fresh_vehicle()
    snap = v.snapshot()
    bad_sim = snap.sim.model_copy(update={"time_s": -1.0})
    with pytest.raises(SnapshotError, match="time_s"):
        Simulator.from_snapshot(bad_sim)
    with pytest.raises(SnapshotError, match="time_s"):
        v.restore(snap.model_copy(update={"sim": bad_sim}))
    nan_air = snap.sim.airframe.model_copy(update={"vn_mps": math.nan})
    with pytest.raises(SnapshotError, match=r"airframe\.vn_mps: Input should be a valid number"):
        Simulator(seed=1).restore(snap.sim.model_copy(update={"airframe": nan_air}))
    with pytest.raises(SnapshotError, match="Invalid JSON"):
        VehicleSnapshot.from_json("{not json")
    v.close()
