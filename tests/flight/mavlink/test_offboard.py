"""Offboard: SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT position and velocity setpoints, entry and loss."""

import math

from pymavlink import mavutil

from flight.mavlink import FlightMode, decode_custom_mode

from .conftest import ACCEPTED, DENIED, mode_of, take_off

m = mavutil.mavlink
POSITION_ONLY = 0b0000_1001_1111_1000  # ignore velocity, acceleration, yaw rate; yaw flown
VELOCITY_ONLY = 0b0000_1101_1100_0111  # ignore position, acceleration, yaw


def stream(link, send, seconds, rate_hz=10.0):
    """Send a setpoint every 1/rate_hz simulated seconds while stepping the vehicle; the last HEARTBEAT seen."""
    every = max(1, round(1.0 / rate_hz / link.vehicle.tick_s))
    heartbeat = None
    for i in range(round(seconds / link.vehicle.tick_s)):
        if i % every == 0:
            send()
        link.step()
        while (msg := link.client.recv_match(blocking=False)) is not None:
            if msg.get_type() == "HEARTBEAT":
                heartbeat = msg
    return heartbeat


def local(link, x, y, z, yaw=0.0, mask=POSITION_ONLY, frame=m.MAV_FRAME_LOCAL_NED):
    return lambda: link.mav.set_position_target_local_ned_send(0, 1, 1, frame, mask, x, y, z, 0, 0, 0, 0, 0, 0, yaw, 0)


def set_offboard(link):
    link.drain()
    link.mav.command_long_send(1, 1, m.MAV_CMD_DO_SET_MODE, 0, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 6, 0, 0, 0, 0, 0)
    return link.wait("COMMAND_ACK", 1.0, lambda a: a.command == m.MAV_CMD_DO_SET_MODE)


def test_local_position_setpoints_fly_and_loss_of_stream_holds(link):
    take_off(link, 5.0)
    assert set_offboard(link).result == DENIED  # no stream yet
    send = local(link, 10.0, 5.0, -8.0, yaw=math.radians(90.0))
    stream(link, send, 0.5)
    send()
    assert set_offboard(link).result == ACCEPTED
    hb = stream(link, send, 15.0)
    assert decode_custom_mode(hb.custom_mode) == (6, 0)
    s = link.vehicle.sim.state()
    assert abs(s.north_m - 10.0) < 0.7 and abs(s.east_m - 5.0) < 0.7 and abs(s.alt_agl_m - 8.0) < 0.5
    assert abs(math.degrees(s.yaw_rad) % 360.0 - 90.0) < 5.0
    # The stream stops: after COM_OF_LOSS_T (1 s) the vehicle holds, with a STATUSTEXT.
    link.run_for(0.8)
    assert mode_of(link) is FlightMode.OFFBOARD
    text = link.wait("STATUSTEXT", 1.0, lambda t: "Offboard setpoints lost" in t.text)
    assert text is not None and mode_of(link) is FlightMode.HOLD
    link.run_for(3.0)
    s2 = link.vehicle.sim.state()
    assert math.hypot(s2.north_m - s.north_m, s2.east_m - s.east_m) < 1.0


def test_velocity_and_global_setpoints(link):
    take_off(link, 5.0)

    def east():  # 2 m/s east, in the body frame rotated by the heading (0 here: north-facing)
        link.mav.set_position_target_local_ned_send(
            0, 1, 1, m.MAV_FRAME_BODY_NED, VELOCITY_ONLY, 0, 0, 0, 0, 2.0, 0, 0, 0, 0, 0, 0
        )

    east()
    assert set_offboard(link).result == ACCEPTED
    stream(link, east, 6.0)
    s = link.vehicle.sim.state()
    assert abs(s.ve_mps - 2.0) < 0.3 and abs(s.vn_mps) < 0.3 and abs(s.alt_agl_m - 5.0) < 0.5
    home = link.vehicle.sim.environment.home
    lat = home.lat_deg + 15.0 / 111_000.0

    def point():
        link.mav.set_position_target_global_int_send(
            0,
            1,
            1,
            m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            POSITION_ONLY | 1024,
            round(lat * 1e7),
            round(home.lon_deg * 1e7),
            7.0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
            0,
        )

    stream(link, point, 20.0)
    s = link.vehicle.sim.state()
    assert abs(s.north_m - 15.0) < 0.7 and abs(s.east_m) < 0.7 and abs(s.alt_agl_m - 7.0) < 0.5
    assert mode_of(link) is FlightMode.OFFBOARD


def test_setpoints_outside_the_fence_or_unflyable_are_ignored(signed_link):
    link = signed_link
    take_off(link, 5.0)
    link.mav.param_set_send(1, 1, b"GF_MAX_HOR_DIST", 50.0, m.MAV_PARAM_TYPE_REAL32)
    near = local(link, 5.0, 0.0, -5.0)
    stream(link, near, 0.3)
    assert set_offboard(link).result == ACCEPTED
    stream(link, local(link, 80.0, 0.0, -5.0), 5.0)  # outside: ignored, the last good setpoint is flown
    assert any("Offboard setpoint ignored: Geofence" in t for _, t in link.vehicle.statustexts)
    assert abs(link.vehicle.sim.state().north_m - 5.0) < 0.7
    accel_only = 0b0000_1100_0011_1111
    stream(link, local(link, 0, 0, 0, mask=accel_only), 0.5)
    assert any("only position and velocity" in t for _, t in link.vehicle.statustexts)
    stream(link, local(link, 0, 0, 0, mask=POSITION_ONLY, frame=m.MAV_FRAME_GLOBAL), 0.5)  # wrong frame
    assert mode_of(link) is FlightMode.OFFBOARD  # bad setpoints still show the stream is alive
