"""MAV_CMD_INJECT_FAILURE on the simulated vehicle: refused unless SYS_FAILURE_EN is 1; battery low and critical,
GPS loss, link loss and a motor off each make the vehicle's own failsafe act; OK restores; nonsense is refused."""

import math

import pytest
from pymavlink import mavutil

from flight.mavlink import FlightMode

from .conftest import ACCEPTED, DENIED, TEMPORARILY_REJECTED, UNSUPPORTED, mode_of, set_param, take_off

m = mavutil.mavlink
INJECT = m.MAV_CMD_INJECT_FAILURE
BATTERY, GPS, MOTOR, LINK = (
    m.FAILURE_UNIT_SYSTEM_BATTERY,
    m.FAILURE_UNIT_SENSOR_GPS,
    m.FAILURE_UNIT_SYSTEM_MOTOR,
    m.FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL,
)
OK, OFF, SLOW = m.FAILURE_TYPE_OK, m.FAILURE_TYPE_OFF, m.FAILURE_TYPE_SLOW


def texts(link):
    return [t for _, t in link.vehicle.statustexts]


@pytest.fixture
def enabled(link):
    answer = set_param(link, "SYS_FAILURE_EN", 1)
    assert answer is not None and link.vehicle.params["SYS_FAILURE_EN"] == 1
    return link


def test_injection_is_refused_while_sys_failure_en_is_0(link):
    assert link.vehicle.params["SYS_FAILURE_EN"] == 0  # PX4's default
    take_off(link, 6.0)
    for unit, kind in ((BATTERY, OFF), (GPS, OFF), (MOTOR, OFF), (LINK, OFF)):
        assert link.command(INJECT, unit, kind, 0).result == DENIED
    assert "Failure injection disabled: set SYS_FAILURE_EN to 1" in texts(link)
    link.run_for(3.0)
    assert link.vehicle.failures.active == [] and link.vehicle.failsafes.triggered == []
    assert mode_of(link) is FlightMode.HOLD and link.vehicle.sim.state().battery_pct > 90.0


def test_battery_low_returns_then_critical_lands_then_ok_reads_true(enabled):
    link = enabled
    take_off(link, 8.0)
    assert link.command(INJECT, BATTERY, SLOW, 0).result == ACCEPTED
    status = link.fresh("BATTERY_STATUS", 3.0)
    assert status.battery_remaining <= 15 and status.charge_state == m.MAV_BATTERY_CHARGE_STATE_LOW
    assert any(t.startswith("Battery low") for t in texts(link))
    assert mode_of(link) is FlightMode.RTL
    assert link.command(INJECT, BATTERY, OFF, 0).result == ACCEPTED
    assert link.wait("STATUSTEXT", 1.0, lambda t: "Battery critical" in t.text) is not None
    assert mode_of(link) is FlightMode.LAND
    assert link.fresh("HEARTBEAT", 2.0).system_status == m.MAV_STATE_CRITICAL
    assert link.vehicle.failsafes.triggered == ["battery_low", "battery_critical"]
    assert link.fly_until(lambda s: not s.armed, 30.0)
    assert link.command(INJECT, BATTERY, OK, 0).result == ACCEPTED
    assert link.fresh("BATTERY_STATUS", 3.0).battery_remaining > 90
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED  # a good battery arms again


def test_gps_loss_reports_no_fix_and_lands_and_ok_restores(enabled):
    link = enabled
    take_off(link, 8.0)
    assert link.fresh("GPS_RAW_INT", 2.0).fix_type == 3
    assert link.command(INJECT, GPS, OFF, 0).result == ACCEPTED
    raw = link.fresh("GPS_RAW_INT", 2.0)
    assert raw.fix_type == 0 and raw.satellites_visible == 0
    assert "GPS lost, no position: landing" in texts(link)
    assert mode_of(link) is FlightMode.LAND and link.vehicle.failsafes.triggered == ["position"]
    assert link.fly_until(lambda s: not s.armed, 30.0)
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == TEMPORARILY_REJECTED  # no fix, no arming
    assert link.command(INJECT, GPS, OK, 0).result == ACCEPTED
    assert link.fresh("GPS_RAW_INT", 2.0).fix_type == 3
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED


def test_link_loss_silences_the_vehicle_and_fires_the_data_link_failsafe(enabled):
    link = enabled
    take_off(link, 6.0)
    set_param(link, "RTL_RETURN_ALT", 8.0)
    ack = link.command(INJECT, LINK, OFF, 0)
    assert ack is not None and ack.result == ACCEPTED  # the ACK still goes out, then nothing
    heard = link.collect("HEARTBEAT", 5.0)
    assert heard == []
    answer = link.command(m.MAV_CMD_NAV_LAND, timeout_s=1.0)
    assert answer is None and mode_of(link) is not FlightMode.LAND  # commands are not read either
    assert link.fly_until(lambda s: link.vehicle.mode is FlightMode.RTL, 8.0)  # COM_DL_LOSS_T 10 s
    assert link.vehicle.failsafes.triggered == ["data_link"]
    assert link.command(INJECT, LINK, OK, 0).result == ACCEPTED
    assert link.wait("HEARTBEAT", 2.0) is not None  # the vehicle is heard again
    assert link.wait("STATUSTEXT", 2.0, lambda t: "Data link regained" in t.text) is not None  # our next heartbeat
    assert "Failure cleared: MAVLink signal" in texts(link)


def test_a_motor_off_brings_the_f450_down_and_it_disarms_on_impact(enabled):
    link = enabled
    take_off(link, 15.0)
    assert link.command(INJECT, MOTOR, OFF, 2).result == ACCEPTED
    assert link.vehicle.sim.motors_failed == frozenset({1})
    assert link.fly_until(lambda s: not s.armed, 20.0)
    s = link.vehicle.sim.state()
    assert s.landed and s.alt_agl_m < 0.5
    said = texts(link)
    assert "Failure injected: motor 2 off" in said and "Motor failure: impact, disarmed" in said
    assert "Critical failure detected: attitude (motor off)" in said
    assert link.command(INJECT, MOTOR, OK, 2).result == ACCEPTED
    assert link.vehicle.sim.motors_failed == frozenset() and link.vehicle.failures.active == []


@pytest.mark.parametrize(
    ("unit", "kind", "instance", "result"),
    [
        (50, OFF, 0, DENIED),  # not a failure unit
        (BATTERY, 42, 0, DENIED),  # not a failure type
        (math.nan, OFF, 0, DENIED),
        (GPS, math.inf, 0, DENIED),
        (GPS, OFF, -1, DENIED),
        (BATTERY, 0.5, 0, DENIED),
        (m.FAILURE_UNIT_SENSOR_GYRO, OFF, 0, UNSUPPORTED),  # real, not simulated here
        (BATTERY, m.FAILURE_TYPE_GARBAGE, 0, UNSUPPORTED),
        (BATTERY, OFF, 2, UNSUPPORTED),  # one battery
        (MOTOR, OFF, 9, UNSUPPORTED),  # four motors
    ],
)
def test_malformed_or_unsupported_injections_are_refused_and_change_nothing(enabled, unit, kind, instance, result):
    link = enabled
    take_off(link, 5.0)
    assert link.command(INJECT, unit, kind, instance).result == result
    assert link.vehicle.failures.active == []
    link.run_for(2.0)
    assert link.vehicle.sim.armed and mode_of(link) is FlightMode.HOLD
    assert link.fresh("HEARTBEAT", 2.0) is not None


def test_sys_failure_en_accepts_only_0_and_1(link):
    answer = set_param(link, "SYS_FAILURE_EN", 7)
    assert answer is not None and link.vehicle.params["SYS_FAILURE_EN"] == 0
    assert any("SYS_FAILURE_EN: 7 out of range" in t for t in texts(link))


def test_failures_are_not_in_snapshots_and_restoring_one_clears_them(enabled):
    vehicle = enabled.vehicle
    snap = vehicle.snapshot()
    vehicle.inject_failure(GPS, OFF)
    vehicle.inject_failure(BATTERY, OFF)
    assert vehicle.failures.active == ["battery critical", "gps off"]
    vehicle.restore(snap)
    assert vehicle.failures.active == [] and not vehicle.sim.gps_lost
    assert vehicle.sim.battery.soc_cap is None and vehicle.sim.gps_fix().fix_type == 3


WRONG = m.FAILURE_TYPE_WRONG


def test_a_battery_level_reads_as_set_and_the_vehicle_acts_on_what_it_reads(enabled):
    """Ours, documented: battery WRONG with param4 = the level in percent (a schedule's battery=18%)."""
    link = enabled
    take_off(link, 6.0)
    assert link.command(INJECT, BATTERY, WRONG, 0, 18.0).result == ACCEPTED
    assert link.fresh("BATTERY_STATUS", 3.0).battery_remaining == 18
    assert "Failure injected: battery reads 18%" in texts(link)
    link.run_for(2.0)
    assert mode_of(link) is FlightMode.HOLD and link.vehicle.failsafes.triggered == []  # above BAT_LOW_THR (15 %)
    assert link.command(INJECT, BATTERY, WRONG, 0, 12.0).result == ACCEPTED
    assert link.wait("STATUSTEXT", 2.0, lambda t: "Battery low" in t.text) is not None
    assert mode_of(link) is FlightMode.RTL and link.vehicle.failures.active == ["battery level"]
    assert link.command(INJECT, BATTERY, OK, 0).result == ACCEPTED
    assert link.fresh("BATTERY_STATUS", 3.0).battery_remaining > 90


@pytest.mark.parametrize("level", [math.nan, -1.0, 100.5, math.inf])
def test_a_battery_level_that_is_not_a_percentage_is_refused_and_changes_nothing(enabled, level):
    link = enabled
    assert link.command(INJECT, BATTERY, WRONG, 0, level).result == DENIED
    assert link.vehicle.failures.active == [] and link.vehicle.sim.battery.soc_cap is None
    assert any("is not 0 to 100 percent" in t for t in texts(link))
