"""Failsafes enforced by the vehicle: geofence breach actions, maximum altitude, battery, data-link loss."""

import math

import pytest
from pymavlink import mavutil

from flight.mavlink import FlightMode, MavlinkVehicle
from flight.sim import Simulator

from .conftest import ACCEPTED, DENIED, mode_of, set_param, take_off

m = mavutil.mavlink


def texts(link):
    return [t for _, t in link.vehicle.statustexts]


def test_default_geofence_is_ours_and_denies_a_takeoff_above_it(link):
    params = link.vehicle.params
    assert params["GF_MAX_HOR_DIST"] == 1500.0 and params["GF_MAX_VER_DIST"] == 120.0 and params["GF_ACTION"] == 2
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    home_alt = link.vehicle.sim.environment.home.alt_msl_m
    ack = link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, home_alt + 130.0)
    assert ack.result == DENIED and any("ceiling" in t for t in texts(link))


@pytest.mark.parametrize(
    ("action", "mode", "armed"),
    [
        (1, FlightMode.HOLD, True),  # warning only: nothing changes
        (2, FlightMode.HOLD, True),
        (3, FlightMode.RTL, True),
        (4, FlightMode.HOLD, False),  # terminate: motors cut
        (5, FlightMode.LAND, True),
    ],
)
def test_vertical_breach_triggers_gf_action(signed_link, action, mode, armed):
    link = signed_link
    take_off(link, 10.0)
    assert link.vehicle.failsafes.triggered == []
    assert set_param(link, "GF_ACTION", action) is not None
    link.mav.param_set_send(1, 1, b"GF_MAX_VER_DIST", 8.0, m.MAV_PARAM_TYPE_REAL32)  # the ceiling drops below us
    text = link.wait("STATUSTEXT", 1.0, lambda t: "Geofence breached" in t.text)
    assert text is not None and text.severity == m.MAV_SEVERITY_CRITICAL
    assert link.vehicle.failsafes.triggered == ["geofence"]
    assert mode_of(link) is mode and link.vehicle.sim.armed is armed
    if action == 2:  # holds just inside the fence
        assert link.fly_until(lambda s: abs(s.alt_agl_m - 7.0) < 0.3, 10.0)
        link.run_for(2.0)
        assert link.vehicle.failsafes.triggered == ["geofence"]  # acted once


def test_horizontal_breach_returns_home(signed_link):
    link = signed_link
    take_off(link, 6.0)
    set_param(link, "GF_ACTION", 3)
    set_param(link, "RTL_RETURN_ALT", 8.0)
    home = link.vehicle.sim.environment.home
    north = home.lat_deg + 30.0 / 111_000.0
    assert link.command(m.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, north, home.lon_deg, math.nan).result == 0
    assert link.fly_until(lambda s: s.north_m > 28.0, 20.0)
    set_param(link, "GF_MAX_HOR_DIST", 20.0)
    assert link.wait("STATUSTEXT", 1.0, lambda t: "Geofence breached (" in t.text) is not None
    assert mode_of(link) is FlightMode.RTL
    assert link.fly_until(lambda s: not s.armed, 60.0)
    s = link.vehicle.sim.state()
    assert math.hypot(s.north_m, s.east_m) < 1.5


def test_battery_low_returns_and_critical_lands(link):
    take_off(link, 6.0)
    battery = link.vehicle.sim.battery
    battery.used_mah = 0.86 * battery.config.capacity_mah  # 14 % left: below BAT_LOW_THR (15 %)
    text = link.wait("STATUSTEXT", 1.0, lambda t: "Battery low" in t.text)
    assert text is not None and mode_of(link) is FlightMode.RTL
    link.run_for(1.0)
    battery.used_mah = 0.94 * battery.config.capacity_mah  # 6 %: below BAT_CRIT_THR (7 %)
    text = link.wait("STATUSTEXT", 1.0, lambda t: "Battery critical" in t.text)
    assert text is not None and mode_of(link) is FlightMode.LAND
    assert link.wait("HEARTBEAT", 2.0).system_status == m.MAV_STATE_CRITICAL
    assert link.vehicle.failsafes.triggered == ["battery_low", "battery_critical"]
    assert link.fly_until(lambda s: not s.armed, 30.0)


def test_data_link_loss_returns_and_recovery_is_reported(link):
    take_off(link, 6.0)
    set_param(link, "RTL_RETURN_ALT", 8.0)
    link.gcs_heartbeat = False
    link.run_for(9.0)
    assert mode_of(link) is FlightMode.HOLD  # COM_DL_LOSS_T is 10 s
    assert link.fly_until(lambda s: link.vehicle.mode is FlightMode.RTL, 2.0)
    assert any("Data link lost" in t for t in texts(link))
    link.gcs_heartbeat = True
    assert link.wait("STATUSTEXT", 2.0, lambda t: "Data link regained" in t.text) is not None
    assert mode_of(link) is FlightMode.RTL  # the return goes on
    assert link.vehicle.failsafes.triggered == ["data_link"]


def test_data_link_loss_action_can_be_disabled(link):
    set_param(link, "NAV_DLL_ACT", 0)
    take_off(link, 5.0)
    link.gcs_heartbeat = False
    link.run_for(12.0)
    assert mode_of(link) is FlightMode.HOLD and any("Data link lost" in t for t in texts(link))


def test_no_data_link_failsafe_before_any_peer_is_heard():
    with MavlinkVehicle(Simulator(seed=2), gcs=None, api=None) as vehicle:
        vehicle.navigator.arm()
        vehicle.navigator.takeoff(5.0)
        vehicle.run_for(20.0)
        assert vehicle.mode is FlightMode.HOLD and vehicle.failsafes.triggered == []
        assert abs(vehicle.sim.state().alt_agl_m - 5.0) < 0.5
