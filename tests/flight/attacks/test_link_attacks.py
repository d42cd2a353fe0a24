"""Attacks on the vehicle's per-link state and its armed-vehicle rules, from strangers on other sockets."""

import math

from pymavlink.dialects.v20 import common as mavlink2

from flight.mavlink.commands import FORCE_MAGIC
from flight.px4 import FlightMode
from tests.flight.mavlink.conftest import ACCEPTED, DENIED, set_param, take_off

m = mavlink2
ARM = m.MAV_CMD_COMPONENT_ARM_DISARM


def test_a_forced_disarm_in_flight_from_an_unsigned_link_is_refused(open_vehicle, attackers):
    link = open_vehicle
    take_off(link, 10.0)
    stranger = attackers(link.vehicle.address)
    stranger.command(ARM, 0, FORCE_MAGIC)
    link.run_for(0.5)
    assert link.vehicle.sim.armed and abs(link.vehicle.sim.state().alt_agl_m - 10.0) < 1.0
    assert any(a.get_type() == "COMMAND_ACK" and a.result == DENIED for a in stranger.listen())
    assert link.command(ARM, 0, FORCE_MAGIC).result == DENIED  # the unsigned ground station cannot either
    assert link.vehicle.security()["refused_disarms"] == 2


def test_fence_and_failsafe_parameters_cannot_be_changed_in_the_air_unsigned(open_vehicle, attackers):
    link = open_vehicle
    take_off(link, 10.0)
    stranger = attackers(link.vehicle.address)
    for name, value in (("GF_MAX_HOR_DIST", 0.0), ("GF_MAX_VER_DIST", 0.0), ("NAV_DLL_ACT", 0)):
        kind = link.vehicle.params.specs[name].param_type
        field = float(value) if kind == m.MAV_PARAM_TYPE_REAL32 else 0.0  # 0 is 0 bytewise too
        stranger.send(stranger.mav.param_set_encode(1, 1, name.encode(), field, kind))
    link.run_for(0.5)
    assert link.vehicle.params["GF_MAX_HOR_DIST"] == 1500.0 and link.vehicle.params["GF_MAX_VER_DIST"] == 120.0
    assert link.vehicle.params["NAV_DLL_ACT"] == 2
    assert link.vehicle.security()["refused_params"] == 3
    assert set_param(link, "MIS_TAKEOFF_ALT", 4.0).param_value == 4.0  # not a safety parameter: allowed


def test_a_signed_link_may_change_the_fence_in_the_air(signed):
    take_off(signed, 10.0)
    assert set_param(signed, "GF_MAX_HOR_DIST", 800.0).param_value == 800.0
    assert signed.vehicle.params["GF_MAX_HOR_DIST"] == 800.0


def test_set_message_interval_from_a_stranger_silences_only_the_stranger(open_vehicle, attackers):
    link = open_vehicle
    stranger = attackers(link.vehicle.address)
    for msg_id in (m.MAVLINK_MSG_ID_HEARTBEAT, m.MAVLINK_MSG_ID_GLOBAL_POSITION_INT):
        stranger.command(m.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, -1)
    link.run_for(0.5)
    stranger.listen()
    assert len(link.collect("GLOBAL_POSITION_INT", 2.0)) >= 9  # the ground station's 5 Hz is untouched
    assert len(link.collect("HEARTBEAT", 2.0)) >= 2
    assert not [msg for msg in stranger.listen() if msg.get_type() in ("HEARTBEAT", "GLOBAL_POSITION_INT")]


def test_twenty_chattering_sockets_cannot_push_the_ground_station_out(open_vehicle, attackers):
    link = open_vehicle
    link.run_for(1.1)  # the ground station's first heartbeat
    gcs = link.vehicle.links.commander
    assert gcs is not None  # the harness's heartbeats made it the commanding ground station
    crowd = [attackers(link.vehicle.address, system_id=100 + i) for i in range(20)]
    for _ in range(3):
        for member in crowd:
            member.send(member.mav.heartbeat_encode(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_PX4, 0, 0, 0))
        link.run_for(0.2)
    assert gcs[0] in link.vehicle.peers and len(link.vehicle.peers) == 16
    assert link.vehicle.security()["evicted_peers"] >= 5
    assert len(link.collect("GLOBAL_POSITION_INT", 2.0)) >= 9  # its telemetry goes on at full rate


def test_a_quadrotor_heartbeat_or_an_impostor_does_not_keep_the_data_link_alive(open_vehicle, attackers):
    link = open_vehicle
    take_off(link, 6.0)
    link.gcs_heartbeat = False
    quad = attackers(link.vehicle.address, system_id=42)
    impostor = attackers(link.vehicle.address, system_id=255)  # the ground station's id, another address
    for _ in range(12):
        quad.send(quad.mav.heartbeat_encode(m.MAV_TYPE_QUADROTOR, m.MAV_AUTOPILOT_PX4, 0, 0, 0))
        impostor.send(impostor.mav.heartbeat_encode(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0))
        link.run_for(1.0)
    assert link.vehicle.failsafes.triggered == ["data_link"] and link.vehicle.mode is FlightMode.RTL
    assert link.vehicle.security()["gcs_impostors"] >= 9


def test_a_peer_reopening_uploads_cannot_block_another_peers_upload(open_vehicle, attackers):
    link = open_vehicle
    stranger = attackers(link.vehicle.address, system_id=200)
    home = link.vehicle.sim.environment.home

    def item(seq, north_deg):
        lat, lon = round((home.lat_deg + north_deg) * 1e7), round(home.lon_deg * 1e7)
        return link.mav.mission_item_int_encode(
            1, 1, seq, m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, m.MAV_CMD_NAV_WAYPOINT, 0, 1, 0, 1, 0, math.nan,
            lat, lon, 10.0, 0,
        )  # fmt: skip

    stranger.send(stranger.mav.mission_count_encode(1, 1, 5, 0))
    link.run_for(0.1)
    link.mav.mission_count_send(1, 1, 2, 0)
    for seq in range(2):
        request = link.wait("MISSION_REQUEST_INT", 2.0, lambda r: r.target_system == 255)
        assert request is not None and request.seq == seq
        stranger.send(stranger.mav.mission_count_encode(1, 1, 5, 0))  # reopened, again and again
        link.mav.send(item(seq, 0.0001 * (seq + 1)))
    ack = link.wait("MISSION_ACK", 2.0, lambda a: a.target_system == 255)
    assert ack is not None and ack.type == ACCEPTED and link.vehicle.missions.store.count(0) == 2


def _ack_to(link, attacker, ticks=50):
    for _ in range(ticks):
        link.step()
        acks = [a for a in attacker.listen() if a.get_type() == "MISSION_ACK"]
        if acks:
            return acks[-1]
    return None


def test_the_fence_plan_cannot_be_replaced_or_cleared_in_the_air_unsigned(open_vehicle, attackers):
    link = open_vehicle
    take_off(link, 8.0)
    stranger = attackers(link.vehicle.address, system_id=200)
    fence = m.MAV_MISSION_TYPE_FENCE
    stranger.send(stranger.mav.mission_clear_all_encode(1, 1, fence))
    ack = _ack_to(link, stranger)
    assert ack is not None and ack.type == m.MAV_MISSION_ERROR
    home = link.vehicle.sim.environment.home
    stranger.send(stranger.mav.mission_count_encode(1, 1, 1, fence))
    link.run_for(0.1)
    circle = stranger.mav.mission_item_int_encode(
        1, 1, 0, m.MAV_FRAME_GLOBAL, m.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, 0, 1, 5000.0, 0, 0, 0,
        round(home.lat_deg * 1e7), round(home.lon_deg * 1e7), 0, fence,
    )  # fmt: skip
    stranger.send(circle)
    ack = _ack_to(link, stranger)
    assert ack is not None and ack.type == m.MAV_MISSION_ERROR
    assert link.vehicle.missions.store.count(fence) == 0 and link.vehicle.security()["refused_params"] == 2
