"""Safety the vehicle enforces whatever its client asks: the floor, the return altitude under the ceiling, offboard
velocity stopped at the fence before a breach, and disarming in the air only on the force code."""

import math

import pytest
from pymavlink import mavutil

from flight.geodesy import offset_position
from flight.mavlink import FlightMode
from flight.mavlink.geofence import Polygon

from .conftest import ACCEPTED, DENIED, TEMPORARILY_REJECTED, mode_of, set_param, take_off
from .test_mission import mission_current, upload, wp

m = mavutil.mavlink
FORCE = 21196
NAN = math.nan
IGNORE_POSITION = 0b111
IGNORE_VELOCITY = 0b111000
IGNORE_ACCEL_YAW = 0b110111000000


def texts(link):
    return [t for _, t in link.vehicle.statustexts]


def alt_now(link):
    return link.vehicle.sim.state().alt_agl_m


def reposition_int(link, frame, z, north=5.0, east=0.0):
    home = link.vehicle.sim.environment.home
    lat, lon = offset_position(home.lat_deg, home.lon_deg, north, east)
    params = (-1.0, 1.0, 0.0, NAN)
    return link.command_int(m.MAV_CMD_DO_REPOSITION, frame, params, round(lat * 1e7), round(lon * 1e7), z)


# -- 1. the floor ---------------------------------------------------------------------------------------------


def test_the_floor_is_a_parameter_with_a_sane_default(link):
    assert link.vehicle.params["GF_MIN_ALT"] == 2.0
    answer = set_param(link, "GF_MIN_ALT", 3.5)
    assert answer is not None and answer.param_value == pytest.approx(3.5)


def test_a_reposition_to_sea_level_300_m_below_home_is_denied(link):
    take_off(link, 8.0)
    home = link.vehicle.sim.environment.home
    assert home.alt_msl_m > 100.0  # so that 0 m above sea level is far below home
    ack = link.command(m.MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, home.lat_deg, home.lon_deg, 0.0)
    assert ack.result == DENIED
    assert any("below the 2.0 m floor" in t for t in texts(link))
    link.run_for(3.0)
    assert alt_now(link) == pytest.approx(8.0, abs=0.5)  # the vehicle did not go anywhere


@pytest.mark.parametrize(
    ("frame", "height", "accepted"),
    [
        (m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, -5.0, False),  # 5 m under home
        (m.MAV_FRAME_GLOBAL_RELATIVE_ALT, 1.0, False),
        (m.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 1.5, False),  # terrain frames are above home here: still too low
        (m.MAV_FRAME_GLOBAL_INT, 1.0, False),  # AMSL: home + 1 m looks like a big number, and is still too low
        (m.MAV_FRAME_GLOBAL, -300.0, False),
        (m.MAV_FRAME_GLOBAL_INT, 4.0, True),
        (m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 2.0, True),  # the floor itself is allowed
    ],
)
def test_command_int_altitude_frames_cannot_slip_under_the_floor(link, frame, height, accepted):
    take_off(link, 6.0)
    amsl = frame in (m.MAV_FRAME_GLOBAL, m.MAV_FRAME_GLOBAL_INT)
    z = height + (link.vehicle.sim.environment.home.alt_msl_m if amsl else 0.0)
    ack = reposition_int(link, frame, z)
    assert ack.result == (ACCEPTED if accepted else DENIED)
    if accepted:
        assert link.fly_until(lambda s: abs(s.alt_agl_m - height) < 0.3, 20.0)
    else:
        assert any("floor" in t for t in texts(link))
        link.run_for(2.0)
        assert alt_now(link) > 5.0


def test_with_the_floor_off_a_low_reposition_is_flown(signed_link):
    link = signed_link
    take_off(link, 6.0)
    set_param(link, "GF_MIN_ALT", 0.0)
    assert reposition_int(link, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 1.0).result == ACCEPTED
    assert link.fly_until(lambda s: abs(s.alt_agl_m - 1.0) < 0.3, 20.0)


def test_take_off_and_landing_are_not_held_to_the_floor(link):
    set_param(link, "GF_MIN_ALT", 5.0)
    take_off(link, 1.5)  # a take-off to below the floor is still a take-off
    assert link.command(m.MAV_CMD_NAV_LAND).result == ACCEPTED
    assert link.fly_until(lambda s: not s.armed, 30.0)


def send_local(link, frame, x=0.0, y=0.0, z=0.0, vx=0.0, vy=0.0, vz=0.0, velocity=False):
    mask = IGNORE_ACCEL_YAW | (IGNORE_POSITION if velocity else IGNORE_VELOCITY)
    link.mav.set_position_target_local_ned_send(0, 1, 1, frame, mask, x, y, z, vx, vy, vz, 0, 0, 0, 0, 0)


def send_global(link, frame, alt, north=0.0, east=0.0):
    home = link.vehicle.sim.environment.home
    lat, lon = offset_position(home.lat_deg, home.lon_deg, north, east)
    mask = IGNORE_ACCEL_YAW | IGNORE_VELOCITY
    link.mav.set_position_target_global_int_send(
        0, 1, 1, frame, mask, round(lat * 1e7), round(lon * 1e7), alt, 0, 0, 0, 0, 0, 0, 0, 0
    )


def enter_offboard_at(link, alt_m):
    """Hold at ``alt_m`` in Offboard (a local position setpoint streamed until the switch is accepted)."""
    take_off(link, alt_m)
    send_local(link, m.MAV_FRAME_LOCAL_NED, z=-alt_m)
    link.step()
    assert link.command(m.MAV_CMD_DO_SET_MODE, 1, 6, 0).result == ACCEPTED
    assert mode_of(link) is FlightMode.OFFBOARD


def stream(link, send, seconds, every_s=0.2):
    """Call ``send()`` every ``every_s`` of simulated time for ``seconds``, stepping the vehicle; yields each tick."""
    next_send = 0.0
    t0 = link.vehicle.sim.time_s
    while link.vehicle.sim.time_s - t0 < seconds:
        if link.vehicle.sim.time_s - t0 >= next_send:
            send()
            next_send += every_s
        link.step()
        link.drain()
        yield link.vehicle.sim.truth()


@pytest.mark.parametrize(
    ("send", "why"),
    [
        (lambda link, home: send_local(link, m.MAV_FRAME_LOCAL_NED, z=3.0), "positive down: under the ground"),
        (lambda link, home: send_local(link, m.MAV_FRAME_LOCAL_NED, z=-1.0), "1 m up"),
        (lambda link, home: send_local(link, m.MAV_FRAME_LOCAL_OFFSET_NED, z=5.0), "5 m lower than now: 1 m"),
        (lambda link, home: send_global(link, m.MAV_FRAME_GLOBAL_INT, home + 1.0), "AMSL: home + 1 m"),
        (lambda link, home: send_global(link, m.MAV_FRAME_GLOBAL_INT, 0.0), "AMSL 0: 300 m under home"),
        (lambda link, home: send_global(link, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 1.0), "1 m above home"),
        (lambda link, home: send_global(link, m.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, -2.0), "under the terrain"),
    ],
)
def test_offboard_position_setpoints_under_the_floor_are_ignored(link, send, why):
    enter_offboard_at(link, 6.0)
    home = link.vehicle.sim.environment.home.alt_msl_m
    lowest = min(s.alt_agl_m for s in stream(link, lambda: send(link, home), 4.0))
    assert lowest > 5.0, why
    assert mode_of(link) is FlightMode.OFFBOARD  # the stream is alive: ignored setpoints still count as heard
    assert any("Offboard setpoint ignored: Geofence: target" in t and "floor" in t for t in texts(link))


def test_a_mission_waypoint_under_the_floor_makes_the_plan_invalid(link):
    items = [
        wp(link, 0, 0, 5.0, command=m.MAV_CMD_NAV_TAKEOFF),
        wp(link, 20, 0, 1.0),
        wp(link, 0, 0, 0.0, m.MAV_CMD_NAV_LAND),
    ]
    ack, _ = upload(link, items)
    assert ack.type == m.MAV_MISSION_ACCEPTED  # stored, as PX4 stores a plan its feasibility check rejects
    assert link.wait("STATUSTEXT", 1.0, lambda t: t.text == "Waypoint 2 is below the 2.0 m floor") is not None
    assert mission_current(link, lambda c: c.total == 3).mission_state == m.MISSION_STATE_NO_MISSION
    assert link.command(m.MAV_CMD_MISSION_START, 0, 0).result == DENIED
    assert not link.vehicle.sim.armed
    # the take-off and landing items, at 5 m and 0 m, are not what made it invalid: lowering the floor fixes it
    set_param(link, "GF_MIN_ALT", 0.5)
    assert mission_current(link, lambda c: c.mission_state != m.MISSION_STATE_NO_MISSION) is not None


# -- 2. the return altitude under the ceiling ----------------------------------------------------------------


def test_rtl_never_climbs_above_a_25_m_ceiling(link):
    assert link.vehicle.params["RTL_RETURN_ALT"] == 60.0
    set_param(link, "GF_MAX_VER_DIST", 25.0)
    take_off(link, 10.0)
    assert reposition_int(link, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 10.0, north=30.0).result == ACCEPTED
    assert link.fly_until(lambda s: s.north_m > 29.0, 30.0)
    assert link.command(m.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == ACCEPTED
    highest = 0.0
    for _ in range(round(90.0 / link.vehicle.tick_s)):
        link.step()
        link.drain()
        s = link.vehicle.sim.state()
        highest = max(highest, s.alt_agl_m)
        if not s.armed:
            break
    assert not link.vehicle.sim.armed, "the return did not end in a landing"
    assert 20.0 < highest < 25.0  # it climbed for the return, to 1 m under the ceiling, not to 60 m
    assert link.vehicle.failsafes.triggered == []
    s = link.vehicle.sim.state()
    assert math.hypot(s.north_m, s.east_m) < 1.5


def test_rtl_from_above_a_lowered_ceiling_descends_to_it(signed_link):
    link = signed_link
    take_off(link, 12.0)
    set_param(link, "GF_ACTION", 1)  # warn only: the breach must not hide what the return does
    set_param(link, "GF_MAX_VER_DIST", 8.0)
    assert link.vehicle.navigator.return_altitude(12.0) == 7.0
    assert link.command(m.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == ACCEPTED
    assert link.fly_until(lambda s: s.alt_agl_m < 7.5, 20.0)


# -- 3. offboard velocity stopped at the fence ---------------------------------------------------------------


def fly_velocity(link, vx, vy, vz, seconds):
    send = lambda: send_local(link, m.MAV_FRAME_LOCAL_NED, vx=vx, vy=vy, vz=vz, velocity=True)  # noqa: E731
    return list(stream(link, send, seconds))


def test_offboard_velocity_towards_a_200_m_fence_stops_before_it_for_120_s(link):
    set_param(link, "GF_MAX_HOR_DIST", 200.0)
    set_param(link, "GF_MAX_VER_DIST", 25.0)
    enter_offboard_at(link, 10.0)
    mark = len(link.vehicle.statustexts)
    t0 = link.vehicle.sim.time_s
    states = fly_velocity(link, 8.0, 0.0, -3.0, 120.0)  # out at full speed, climbing at full rate
    assert max(math.hypot(s.north_m, s.east_m) for s in states) <= 201.0
    assert max(s.alt_agl_m for s in states) <= 26.0
    assert max(s.north_m for s in states) > 190.0  # it did fly out to the fence, it did not stop early
    assert link.vehicle.failsafes.triggered == []  # stopped before a breach, not after
    assert mode_of(link) is FlightMode.OFFBOARD
    said = [t for _, t in list(link.vehicle.statustexts)[mark:] if "velocity limited" in t]
    elapsed = link.vehicle.sim.time_s - t0
    assert 1 <= len(said) <= elapsed + 1  # said, at most once a second


def test_without_prediction_the_same_stream_breaches_the_fence(link):
    set_param(link, "GF_PREDICT", 0)
    set_param(link, "GF_MAX_HOR_DIST", 60.0)
    enter_offboard_at(link, 10.0)
    states = fly_velocity(link, 8.0, 0.0, 0.0, 20.0)
    assert max(s.north_m for s in states) > 61.0
    assert link.vehicle.failsafes.triggered == ["geofence"]


def test_offboard_velocity_stops_at_an_uploaded_polygon_and_at_the_floor(link):
    enter_offboard_at(link, 10.0)
    square = Polygon(((-40.0, -40.0), (40.0, -40.0), (40.0, 40.0), (-40.0, 40.0)), inclusion=True)
    link.vehicle.navigator.fence.areas = (square,)
    states = fly_velocity(link, 4.0, 6.0, 0.0, 40.0)  # diagonally at the east side
    assert max(s.east_m for s in states) <= 41.0 and max(s.north_m for s in states) <= 41.0
    assert max(s.east_m for s in states) > 35.0
    states = fly_velocity(link, 0.0, 0.0, 1.5, 20.0)  # straight down at the ground
    assert min(s.alt_agl_m for s in states) >= 1.0  # floor 2 m, no more than 1 m under it
    assert link.vehicle.sim.armed and link.vehicle.failsafes.triggered == []


def test_a_velocity_along_the_fence_is_not_slowed(link):
    set_param(link, "GF_MAX_HOR_DIST", 30.0)
    enter_offboard_at(link, 10.0)
    fly_velocity(link, 5.0, 0.0, 0.0, 15.0)  # to the fence, north
    east_before = link.vehicle.sim.truth().east_m
    states = fly_velocity(link, 0.0, 3.0, 0.0, 3.0)  # along it (tangent, at first)
    assert states[-1].east_m - east_before > 5.0


# -- 4. disarm in the air only on the force code -------------------------------------------------------------


def test_a_plain_disarm_in_flight_is_refused_and_the_vehicle_flies_on(link):
    take_off(link, 8.0)
    ack = link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 0)
    assert ack.result == TEMPORARILY_REJECTED  # PX4's answer to a refused disarm (``Commander.cpp``)
    assert "Disarming denied: not landed" in texts(link)
    for wrong in (2989.0, 21195.0, 21196.5):  # the force-arm code, near misses
        assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 0, wrong).result == TEMPORARILY_REJECTED
    link.run_for(2.0)
    assert link.vehicle.sim.armed and alt_now(link) == pytest.approx(8.0, abs=0.5)


def test_a_forced_disarm_in_flight_stops_the_motors(signed_link):
    link = signed_link
    take_off(link, 8.0)
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 0, FORCE).result == ACCEPTED
    assert not link.vehicle.sim.armed
    assert link.fly_until(lambda s: s.landed, 10.0)  # it fell


def test_from_outside_the_fence_a_velocity_back_inside_is_not_turned_round(link):
    set_param(link, "GF_ACTION", 1)  # warn only, so the vehicle stays outside and under offboard control
    enter_offboard_at(link, 10.0)
    fly_velocity(link, 5.0, 0.0, 0.0, 8.0)  # 30 m north or so
    north = link.vehicle.sim.truth().north_m
    set_param(link, "GF_MAX_HOR_DIST", north - 10.0)  # now 10 m outside
    states = fly_velocity(link, -3.0, 0.0, 0.0, 8.0)  # back towards home
    assert states[-1].north_m < north - 10.0
    assert mode_of(link) is FlightMode.OFFBOARD
