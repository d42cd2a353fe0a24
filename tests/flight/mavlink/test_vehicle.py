"""The MAVLink vehicle with pymavlink as the client: identity, flight, commands, parameters, streams, robustness."""

import math
import os
import random
import struct
import time

from pymavlink import mavutil

from flight.mavlink import FlightMode, MavlinkVehicle, decode_custom_mode, encode_custom_mode
from flight.sim import Simulator

from .conftest import ACCEPTED, DENIED, TEMPORARILY_REJECTED, UNSUPPORTED, free_port

m = mavutil.mavlink
HOME_ALT = 300.0


def as_int(field):
    """An INT32 parameter's value from its bytewise-encoded float field."""
    return struct.unpack("<i", struct.pack("<f", field))[0]


def int_field(n):
    return struct.unpack("<f", struct.pack("<i", n))[0]


def test_custom_mode_encoding_is_px4s():
    assert encode_custom_mode(4, 3) == 0x03040000  # AUTO / LOITER ("Hold")
    assert decode_custom_mode(FlightMode.POSITION.custom_mode) == (3, 0)
    assert FlightMode.from_px4(4, 5) is FlightMode.RTL
    assert FlightMode.from_px4(1, 0) is None


def test_heartbeat_presents_a_px4_quadrotor(link):
    hb = link.first_heartbeat
    assert hb is not None
    assert hb.type == m.MAV_TYPE_QUADROTOR and hb.autopilot == m.MAV_AUTOPILOT_PX4
    assert hb.base_mode & m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert not hb.base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED
    assert decode_custom_mode(hb.custom_mode) == (4, 3)
    assert hb.system_status == m.MAV_STATE_STANDBY
    assert hb.get_srcSystem() == 1 and hb.get_srcComponent() == 1
    assert link.client.mavlink20()
    beats = link.collect("HEARTBEAT", 5.0)
    assert len(beats) in (4, 5, 6)


def test_default_streams_arrive(link):
    types = set()
    for _ in range(round(2.5 / link.vehicle.tick_s)):
        link.step()
        while (msg := link.client.recv_match(blocking=False)) is not None:
            types.add(msg.get_type())
    expected = {"HEARTBEAT", "SYS_STATUS", "BATTERY_STATUS", "ATTITUDE", "GLOBAL_POSITION_INT"}
    expected |= {"LOCAL_POSITION_NED", "GPS_RAW_INT", "EXTENDED_SYS_STATE", "HOME_POSITION"}
    assert expected <= types
    gps = link.wait("GPS_RAW_INT", 2.0)
    assert gps.fix_type == 3 and gps.satellites_visible >= 6
    assert abs(gps.lat / 1e7 - 21.4133) < 1e-4
    ess = link.wait("EXTENDED_SYS_STATE", 2.0)
    assert ess.landed_state == m.MAV_LANDED_STATE_ON_GROUND


def test_arm_takeoff_reposition_land(link):
    ack = link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == ACCEPTED and ack.target_system == 255 and ack.target_component == 190
    hb = link.wait("HEARTBEAT", 2.0)
    assert hb.base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED and hb.system_status == m.MAV_STATE_ACTIVE

    assert link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, HOME_ALT + 10.0).result == 0
    hb = link.wait("HEARTBEAT", 2.0)
    assert decode_custom_mode(hb.custom_mode) == (4, 2)  # AUTO / TAKEOFF
    assert link.wait("EXTENDED_SYS_STATE", 2.0).landed_state == m.MAV_LANDED_STATE_TAKEOFF
    assert link.fly_until(lambda s: link.vehicle.mode is FlightMode.HOLD, 15.0)
    pos = link.wait("GLOBAL_POSITION_INT", 1.0)
    assert abs(pos.relative_alt / 1000.0 - 10.0) < 0.6
    assert abs(pos.alt / 1000.0 - (HOME_ALT + 10.0)) < 0.6

    # 30 m north, 15 m altitude above home, in the relative-altitude frame of COMMAND_INT.
    home = link.vehicle.sim.environment.home
    lat = home.lat_deg + 30.0 / 111_000.0
    ack = link.command_int(
        m.MAV_CMD_DO_REPOSITION,
        m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        (-1, m.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0, math.nan),
        round(lat * 1e7),
        round(home.lon_deg * 1e7),
        15.0,
    )
    assert ack.result == ACCEPTED
    link.run_for(15.0)
    pos = link.fresh("GLOBAL_POSITION_INT", 1.0)
    assert abs((pos.lat / 1e7 - lat) * 111_000.0) < 1.5
    assert abs((pos.lon / 1e7 - home.lon_deg) * 111_000.0) < 1.5
    assert abs(pos.relative_alt / 1000.0 - 15.0) < 0.6
    assert link.fresh("EXTENDED_SYS_STATE", 2.0).landed_state == m.MAV_LANDED_STATE_IN_AIR

    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == TEMPORARILY_REJECTED  # in the air
    assert link.command(m.MAV_CMD_NAV_LAND).result == ACCEPTED
    assert link.wait("EXTENDED_SYS_STATE", 2.0).landed_state == m.MAV_LANDED_STATE_LANDING
    assert link.fly_until(lambda s: not s.armed, 40.0)
    pos = link.wait("GLOBAL_POSITION_INT", 1.0)
    assert abs(pos.relative_alt / 1000.0) < 0.3
    assert abs((pos.lat / 1e7 - lat) * 111_000.0) < 2.0
    hb = link.wait("HEARTBEAT", 2.0)
    assert not hb.base_mode & m.MAV_MODE_FLAG_SAFETY_ARMED
    assert decode_custom_mode(hb.custom_mode) == (4, 6)  # AUTO / LAND


def test_takeoff_with_nan_altitude_uses_mis_takeoff_alt_and_rtl_comes_home(link):
    link.mav.param_set_send(1, 1, b"MIS_TAKEOFF_ALT", 6.0, m.MAV_PARAM_TYPE_REAL32)
    assert link.wait("PARAM_VALUE", 1.0).param_value == 6.0
    link.mav.param_set_send(1, 1, b"RTL_RETURN_ALT", 8.0, m.MAV_PARAM_TYPE_REAL32)
    assert link.wait("PARAM_VALUE", 1.0).param_value == 8.0
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, math.nan).result == ACCEPTED
    assert link.fly_until(lambda s: link.vehicle.mode is FlightMode.HOLD, 15.0)
    assert abs(link.vehicle.sim.state().alt_agl_m - 6.0) < 0.6
    home = link.vehicle.sim.environment.home
    # COMMAND_LONG altitude is above mean sea level, as PX4 reads it.
    lon = home.lon_deg + 20.0 / (111_000.0 * math.cos(math.radians(home.lat_deg)))
    ack = link.command(m.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, home.lat_deg, lon, HOME_ALT + 6.0)
    assert ack.result == ACCEPTED
    assert link.fly_until(lambda s: abs(s.east_m - 20.0) < 1.0 and s.groundspeed_mps < 0.3, 20.0)
    assert link.command(m.MAV_CMD_NAV_RETURN_TO_LAUNCH).result == ACCEPTED
    assert link.wait("HEARTBEAT", 2.0, lambda h: decode_custom_mode(h.custom_mode) == (4, 5))
    assert link.fly_until(lambda s: s.alt_agl_m > 7.5, 10.0)  # climbs to RTL_RETURN_ALT first
    assert link.fly_until(lambda s: not s.armed, 60.0)
    s = link.vehicle.sim.state()
    assert math.hypot(s.north_m, s.east_m) < 1.5 and s.landed


def test_unsupported_command_is_answered_unsupported(link):
    ack = link.command(m.MAV_CMD_DO_FENCE_ENABLE, 1)
    assert ack is not None and ack.result == UNSUPPORTED
    ack = link.command(31010)  # MAV_CMD_USER_1
    assert ack is not None and ack.result == UNSUPPORTED


def test_refusals_are_denied_with_a_statustext(link):
    assert link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, math.nan).result == DENIED  # not armed
    assert any("arm first" in t for _, t in link.vehicle.statustexts)
    offboard = link.command(m.MAV_CMD_DO_SET_MODE, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 6, 0)
    assert offboard.result == DENIED
    ack = link.command(m.MAV_CMD_DO_SET_MODE, m.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 3, 0)
    assert ack.result == ACCEPTED
    assert link.wait("HEARTBEAT", 2.0, lambda h: decode_custom_mode(h.custom_mode) == (3, 0))


def test_geofence_denies_a_reposition_outside_the_fence(link):
    link.mav.param_set_send(1, 1, b"GF_MAX_HOR_DIST", 50.0, m.MAV_PARAM_TYPE_REAL32)
    assert link.wait("PARAM_VALUE", 1.0).param_value == 50.0
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED
    assert link.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, HOME_ALT + 5.0).result == 0
    link.run_for(4.0)
    home = link.vehicle.sim.environment.home
    far = home.lat_deg + 100.0 / 111_000.0
    link.drain()
    link.mav.command_long_send(1, 1, m.MAV_CMD_DO_REPOSITION, 0, -1, 1, 0, math.nan, far, home.lon_deg, math.nan)
    text = link.wait("STATUSTEXT", 1.0)
    assert text is not None and "Geofence" in text.text and text.severity == m.MAV_SEVERITY_WARNING
    ack = link.wait("COMMAND_ACK", 1.0)
    assert ack.command == m.MAV_CMD_DO_REPOSITION and ack.result == DENIED
    near = home.lat_deg + 40.0 / 111_000.0
    assert link.command(m.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, near, home.lon_deg, math.nan).result == 0


def test_garbage_is_counted_and_dropped_and_the_vehicle_still_answers(link):
    rng = random.Random(5)
    sock = link.client.port
    addr = link.vehicle.address
    good = link.mav.ping_encode(1234, 7, 0, 0).pack(link.mav)
    junk = [bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300))) for _ in range(40)]
    junk += [good[:n] for n in range(1, len(good))]  # every truncation of a valid packet
    junk += [b"\xfd" * 280, b"", good[:-1] + bytes([good[-1] ^ 0xFF])]  # bad CRC last
    for j in junk:
        sock.sendto(j, addr)
    link.run_for(0.1)
    stats = link.vehicle.stats
    assert stats.rx_dropped >= len(junk) - 2  # a random buffer may, very rarely, hide nothing invalid
    link.mav.ping_send(99, 3, 0, 0)
    pong = link.wait("PING", 1.0)
    assert pong is not None and pong.time_usec == 99 and pong.seq == 3 and pong.target_system == 255
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED


def test_param_read_and_set_round_trip(link):
    link.drain()
    link.mav.param_request_list_send(1, 1)
    values = {}
    for _ in range(50):
        link.step()
        while (msg := link.client.recv_match(type="PARAM_VALUE", blocking=False)) is not None:
            values[msg.param_id] = msg
    assert {"MIS_TAKEOFF_ALT", "RTL_RETURN_ALT", "GF_MAX_HOR_DIST", "GF_ACTION", "COM_DL_LOSS_T"} <= set(values)
    assert values["MIS_TAKEOFF_ALT"].param_value == 2.5
    assert all(v.param_count == len(values) for v in values.values())

    link.mav.param_request_read_send(1, 1, b"COM_DL_LOSS_T", -1)
    v = link.wait("PARAM_VALUE", 1.0)
    assert v.param_type == m.MAV_PARAM_TYPE_INT32
    assert as_int(v.param_value) == 10  # bytewise, as PX4
    link.mav.param_set_send(1, 1, b"GF_ACTION", int_field(3), m.MAV_PARAM_TYPE_INT32)
    v = link.wait("PARAM_VALUE", 1.0, lambda p: p.param_id == "GF_ACTION")
    assert as_int(v.param_value) == 3 and link.vehicle.params["GF_ACTION"] == 3
    link.mav.param_set_send(1, 1, b"RTL_RETURN_ALT", 500.0, m.MAV_PARAM_TYPE_REAL32)  # out of range: unchanged
    v = link.wait("PARAM_VALUE", 1.0, lambda p: p.param_id == "RTL_RETURN_ALT")
    assert v.param_value == 60.0
    idx = values["BAT_LOW_THR"].param_index
    link.mav.param_request_read_send(1, 1, b"", idx)
    v = link.wait("PARAM_VALUE", 1.0)
    assert v.param_id == "BAT_LOW_THR" and abs(v.param_value - 0.15) < 1e-6


def test_set_message_interval_changes_a_stream_rate(link):
    gpi = m.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    assert 8 <= len(link.collect("GLOBAL_POSITION_INT", 2.0)) <= 11  # 5 Hz default
    assert link.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 50_000).result == ACCEPTED  # 20 Hz
    assert 38 <= len(link.collect("GLOBAL_POSITION_INT", 2.0)) <= 42
    link.drain()
    link.mav.command_long_send(1, 1, m.MAV_CMD_GET_MESSAGE_INTERVAL, 0, gpi, 0, 0, 0, 0, 0, 0)
    assert link.wait("MESSAGE_INTERVAL", 1.0).interval_us == 50_000
    assert link.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, -1).result == ACCEPTED
    assert link.collect("GLOBAL_POSITION_INT", 1.0) == []
    assert link.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, gpi, 0).result == ACCEPTED
    assert len(link.collect("GLOBAL_POSITION_INT", 1.0)) >= 4
    assert link.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, 9999, 1000).result == DENIED


def test_request_message_home_and_autopilot_version(link):
    link.drain()
    link.mav.command_long_send(1, 1, m.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
    ver = link.wait("AUTOPILOT_VERSION", 1.0)
    assert ver.capabilities & m.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert ver.capabilities & m.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    link.mav.command_long_send(1, 1, m.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0)
    home = link.wait("HOME_POSITION", 1.0)
    assert abs(home.latitude / 1e7 - 21.4133) < 1e-6 and home.altitude == 300_000
    assert link.command(m.MAV_CMD_REQUEST_MESSAGE, 9999).result == DENIED


def test_gripper_and_servo_release_the_payload(link):
    assert link.command(m.MAV_CMD_DO_GRIPPER, 1, m.GRIPPER_ACTION_GRAB).result == ACCEPTED
    assert link.command(m.MAV_CMD_DO_GRIPPER, 1, m.GRIPPER_ACTION_RELEASE).result == ACCEPTED
    assert link.vehicle.sim.payload_released
    assert link.command(m.MAV_CMD_DO_GRIPPER, 1, m.GRIPPER_ACTION_GRAB).result == DENIED
    assert link.command(m.MAV_CMD_DO_SET_SERVO, 9, 1900).result == ACCEPTED


def test_paced_run_on_a_thread_answers_and_keeps_time():
    assert os.environ.get("MAVLINK20") == "1"
    port = free_port()
    client = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255)
    vehicle = MavlinkVehicle(Simulator(seed=1), gcs=("127.0.0.1", port), api=None)
    try:
        vehicle.start(speed=1.0)
        hb = client.recv_match(type="HEARTBEAT", blocking=True, timeout=3.0)
        assert hb is not None and hb.autopilot == m.MAV_AUTOPILOT_PX4
        t0_wall, t0_sim = time.monotonic(), vehicle.sim.time_s
        client.mav.command_long_send(1, 1, m.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        ack = client.recv_match(type="COMMAND_ACK", blocking=True, timeout=3.0)
        assert ack is not None and ack.result == ACCEPTED
        time.sleep(0.5)
        ratio = (vehicle.sim.time_s - t0_sim) / (time.monotonic() - t0_wall)
        assert 0.7 < ratio < 1.3
        vehicle.stop()
        t_stopped = vehicle.sim.time_s
        vehicle.start(speed=None)
        time.sleep(0.5)
        vehicle.stop()
        assert vehicle.sim.time_s - t_stopped > 2.0  # much faster than real time
    finally:
        vehicle.close()
        client.close()
