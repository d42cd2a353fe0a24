"""The mission protocol on the simulated vehicle, spoken raw with pymavlink in lockstep: upload and download (INT and
legacy messages), clearing, errors, plan types, fences that restrict the vehicle, resends, and a mission flown."""

import math
import socket

import pytest
from pymavlink import mavutil

from agentic_core.contracts.geodesy import offset_position

from .conftest import ACCEPTED, DENIED, take_off

m = mavutil.mavlink
FAILED = 4
UINT16_MAX = 0xFFFF
GLOBAL_REL_INT = m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT


def home_of(link):
    return link.vehicle.sim.environment.home


def wp(link, north, east, alt, command=m.MAV_CMD_NAV_WAYPOINT, params=(0.0, 0.0, 0.0, math.nan)):
    """A global item ``north``/``east`` metres from home at ``alt`` above home, as MISSION_ITEM_INT fields."""
    home = home_of(link)
    lat, lon = offset_position(home.lat_deg, home.lon_deg, north, east)
    return (command, GLOBAL_REL_INT, *params, round(lat * 1e7), round(lon * 1e7), float(alt))


def do(command, *params):
    """A non-positional item (MAV_FRAME_MISSION)."""
    p = [*params, *([0.0] * (7 - len(params)))]
    return (command, m.MAV_FRAME_MISSION, *p[:4], int(p[4]), int(p[5]), p[6])


def send_item(link, seq, item, kind=0, legacy=False, current=0):
    command, frame, p1, p2, p3, p4, x, y, z = item
    if legacy:
        scale = 1e-7 if frame != m.MAV_FRAME_MISSION else 1.0
        link.mav.mission_item_send(1, 1, seq, frame, command, current, 1, p1, p2, p3, p4, x * scale, y * scale, z, kind)
    else:
        link.mav.mission_item_int_send(1, 1, seq, frame, command, current, 1, p1, p2, p3, p4, x, y, z, kind)


def wait_any(link, types, timeout_s=2.0, cond=lambda msg: True):
    """Step until a message of one of ``types`` satisfying ``cond`` arrives."""
    for _ in range(math.ceil(timeout_s / link.vehicle.tick_s) + 1):
        while (msg := link.client.recv_match(blocking=False)) is not None:
            if msg.get_type() in types and cond(msg):
                return msg
        link.step()
    return None


def upload(link, items, kind=0, legacy=False):
    """Upload ``items``, answering each request; returns (the MISSION_ACK, the kinds of request seen)."""
    link.drain()
    link.mav.mission_count_send(1, 1, len(items), kind)
    kinds: list[str] = []
    while True:
        msg = wait_any(link, {"MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"})
        assert msg is not None, "the vehicle went quiet"
        if msg.get_type() == "MISSION_ACK":
            return msg, kinds
        assert msg.mission_type == kind
        kinds.append(msg.get_type())
        send_item(link, msg.seq, items[msg.seq], kind, legacy)


def download(link, kind=0, legacy=False):
    """Download a plan: (MISSION_COUNT, the items as messages)."""
    link.drain()
    link.mav.mission_request_list_send(1, 1, kind)
    count = link.wait("MISSION_COUNT", 2.0)
    assert count is not None and count.mission_type == kind
    got = []
    answer = "MISSION_ITEM" if legacy else "MISSION_ITEM_INT"
    for seq in range(count.count):
        if legacy:
            link.mav.mission_request_send(1, 1, seq, kind)
        else:
            link.mav.mission_request_int_send(1, 1, seq, kind)
        item = link.wait(answer, 2.0, lambda i, seq=seq: i.seq == seq)
        assert item is not None, f"no {answer} {seq}"
        got.append(item)
    link.mav.mission_ack_send(1, 1, m.MAV_MISSION_ACCEPTED, kind)
    link.step()
    return count, got


def texts(link):
    return [t for _, t in link.vehicle.statustexts]


def mission_current(link, cond=lambda c: True, timeout_s=2.0):
    return link.wait("MISSION_CURRENT", timeout_s, cond)


# --- transfers -----------------------------------------------------------------------------------------------


def test_upload_and_download_round_trip_with_int_messages(link):
    items = [
        wp(link, 0, 0, 12, m.MAV_CMD_NAV_TAKEOFF),
        wp(link, 25, 5, 12, params=(2.0, 1.5, 0.0, 90.0)),
        do(m.MAV_CMD_DO_CHANGE_SPEED, 1, 6.5, -1),
        wp(link, 25, -15, 15, m.MAV_CMD_NAV_LOITER_TIME, params=(3.0, 0.0, 0.0, 0.0)),
        (m.MAV_CMD_NAV_RETURN_TO_LAUNCH, m.MAV_FRAME_MISSION, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0),
    ]
    ack, kinds = upload(link, items)
    assert ack.type == m.MAV_MISSION_ACCEPTED and ack.mission_type == 0
    assert ack.target_system == 255 and ack.target_component == 190
    assert kinds == ["MISSION_REQUEST_INT"] * len(items)  # in order, one each
    count, got = download(link)
    assert count.count == len(items)
    for seq, (sent, back) in enumerate(zip(items, got, strict=True)):
        command, frame, p1, p2, p3, _, x, y, z = sent
        assert (back.seq, back.command, back.frame) == (seq, command, frame)
        assert (back.x, back.y) == (x, y) and back.z == pytest.approx(z)
        assert [back.param1, back.param2, back.param3] == pytest.approx([p1, p2, p3])
        assert back.autocontinue == 1 and back.mission_type == 0
        assert back.current == (1 if seq == 0 else 0)
    assert not link.vehicle.missions.busy  # the final ACK ended the download


def test_legacy_mission_item_and_mission_request_are_answered_the_px4_way(link):
    home = home_of(link)
    lat, lon = offset_position(home.lat_deg, home.lon_deg, 40.0, 10.0)
    x, y = round(lat * 1e7), round(lon * 1e7)
    items = [
        (m.MAV_CMD_NAV_WAYPOINT, m.MAV_FRAME_GLOBAL_RELATIVE_ALT, 0.0, 0.0, 0.0, 0.0, x, y, 20.0),
        (m.MAV_CMD_NAV_WAYPOINT, m.MAV_FRAME_GLOBAL, 0.0, 0.0, 0.0, 0.0, x, y, 320.0),
    ]
    ack, kinds = upload(link, items, legacy=True)
    assert ack.type == m.MAV_MISSION_ACCEPTED
    # the first request is MISSION_REQUEST_INT; once the partner answers with legacy items, PX4 asks in kind
    assert kinds == ["MISSION_REQUEST_INT", "MISSION_REQUEST"]
    _, legacy = download(link, legacy=True)
    assert [i.frame for i in legacy] == [m.MAV_FRAME_GLOBAL_RELATIVE_ALT, m.MAV_FRAME_GLOBAL]
    assert all(abs(i.x - lat) < 1e-5 and abs(i.y - lon) < 1e-5 for i in legacy)  # float degrees
    _, as_int = download(link)
    assert [i.frame for i in as_int] == [GLOBAL_REL_INT, m.MAV_FRAME_GLOBAL_INT]
    # MISSION_ITEM carried float32 degrees: a few 1e-7 degrees (centimetres) were lost on the way in
    assert all(abs(i.x - x) <= 50 and abs(i.y - y) <= 50 for i in as_int) and as_int[1].z == pytest.approx(320.0)


def test_clear_all_and_an_empty_upload_clear_the_plan(link):
    assert upload(link, [wp(link, 10, 0, 10)])[0].type == ACCEPTED
    assert mission_current(link, lambda c: c.total == 1) is not None
    link.mav.mission_clear_all_send(1, 1, 0)
    ack = link.wait("MISSION_ACK", 2.0)
    assert ack.type == m.MAV_MISSION_ACCEPTED and ack.mission_type == 0
    assert download(link)[0].count == 0
    current = mission_current(link, lambda c: c.total == UINT16_MAX)
    assert current is not None and current.mission_state == m.MISSION_STATE_NO_MISSION
    assert upload(link, [wp(link, 10, 0, 10)])[0].type == ACCEPTED
    assert upload(link, [])[0].type == ACCEPTED  # a count of 0 clears too
    assert download(link)[0].count == 0


def test_plan_types_are_kept_apart_and_cleared_apart(link):
    mission = [wp(link, 10, 0, 10), wp(link, 20, 0, 10)]
    square = [
        wp(link, n, e, 0, m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, (4.0, 0, 0, 0))
        for n, e in [(-100, -100), (-100, 100), (100, 100), (100, -100)]
    ]
    circle = [wp(link, 50, 50, 0, m.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, (10.0, 0, 0, 0))]
    rally = [wp(link, -20, 0, 15, m.MAV_CMD_NAV_RALLY_POINT)]
    assert upload(link, mission)[0].type == ACCEPTED
    assert upload(link, square + circle, kind=m.MAV_MISSION_TYPE_FENCE)[0].type == ACCEPTED
    assert upload(link, rally, kind=m.MAV_MISSION_TYPE_RALLY)[0].type == ACCEPTED
    assert download(link)[0].count == 2
    count, fence = download(link, kind=m.MAV_MISSION_TYPE_FENCE)
    assert count.count == 5 and [i.command for i in fence] == [5001] * 4 + [5004]
    assert fence[4].param1 == 10.0 and all(i.mission_type == 1 for i in fence)
    assert download(link, kind=m.MAV_MISSION_TYPE_RALLY)[0].count == 1
    link.mav.mission_clear_all_send(1, 1, m.MAV_MISSION_TYPE_FENCE)
    assert link.wait("MISSION_ACK", 2.0).mission_type == m.MAV_MISSION_TYPE_FENCE
    assert download(link, kind=m.MAV_MISSION_TYPE_FENCE)[0].count == 0
    assert download(link)[0].count == 2 and download(link, kind=m.MAV_MISSION_TYPE_RALLY)[0].count == 1
    link.mav.mission_clear_all_send(1, 1, m.MAV_MISSION_TYPE_ALL)
    assert link.wait("MISSION_ACK", 2.0).type == ACCEPTED
    assert [download(link, kind=k)[0].count for k in (0, 1, 2)] == [0, 0, 0]


# --- errors --------------------------------------------------------------------------------------------------


def upload_one_bad(link, item, kind=0):
    """Upload [good, ``item``]; returns the MISSION_ACK that ended it."""
    return upload(link, [wp(link, 10, 0, 10) if kind == 0 else item, item], kind)[0]


def test_items_the_vehicle_cannot_take_end_the_upload_with_the_right_result(link):
    loiter_turns = wp(link, 10, 0, 10, m.MAV_CMD_NAV_LOITER_TURNS)  # PX4 takes no LOITER_TURNS
    assert upload_one_bad(link, loiter_turns).type == m.MAV_MISSION_UNSUPPORTED
    assert any("Invalid item 1" in t for t in texts(link))
    local = (m.MAV_CMD_NAV_WAYPOINT, m.MAV_FRAME_LOCAL_NED, 0.0, 0.0, 0.0, 0.0, 10, 10, -5.0)
    assert upload_one_bad(link, local).type == m.MAV_MISSION_UNSUPPORTED_FRAME
    rtl_with_position = wp(link, 0, 0, 10, m.MAV_CMD_NAV_RETURN_TO_LAUNCH)
    assert upload_one_bad(link, rtl_with_position).type == m.MAV_MISSION_UNSUPPORTED  # PX4: frame 2 only
    fence_in_mission = wp(link, 10, 0, 0, m.MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, (50.0, 0, 0, 0))
    assert upload_one_bad(link, fence_in_mission).type == m.MAV_MISSION_ERROR
    two_vertices = wp(link, 10, 0, 0, m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, (2.0, 0, 0, 0))
    assert upload_one_bad(link, two_vertices, kind=m.MAV_MISSION_TYPE_FENCE).type == m.MAV_MISSION_ERROR
    bad_lat = (m.MAV_CMD_NAV_WAYPOINT, GLOBAL_REL_INT, 0.0, 0.0, 0.0, 0.0, 95 * 10**7, 0, 10.0)
    assert upload_one_bad(link, bad_lat).type == m.MAV_MISSION_INVALID_PARAM5_X
    sky_high = wp(link, 10, 0, 1e9)
    assert upload_one_bad(link, sky_high).type == m.MAV_MISSION_INVALID_PARAM7
    # after each refusal the vehicle is idle again: a good upload goes through, the old plan was never touched
    assert download(link)[0].count == 0
    assert upload(link, [wp(link, 10, 0, 10)])[0].type == ACCEPTED


def test_counts_over_capacity_and_unknown_plan_types_are_refused(link):
    link.mav.mission_count_send(1, 1, 5000, 0)
    assert link.wait("MISSION_ACK", 2.0).type == m.MAV_MISSION_NO_SPACE
    link.mav.mission_count_send(1, 1, 65, m.MAV_MISSION_TYPE_FENCE)
    assert link.wait("MISSION_ACK", 2.0).type == m.MAV_MISSION_NO_SPACE
    link.mav.mission_count_send(1, 1, 2, 7)
    assert link.wait("MISSION_ACK", 2.0).type == m.MAV_MISSION_UNSUPPORTED


def test_out_of_sequence_and_wrong_type_items(link):
    items = [wp(link, 10, 0, 10), wp(link, 20, 0, 10), wp(link, 30, 0, 10)]
    link.drain()
    link.mav.mission_count_send(1, 1, 3, 0)
    assert link.wait("MISSION_REQUEST_INT", 2.0).seq == 0
    send_item(link, 0, items[0])
    assert link.wait("MISSION_REQUEST_INT", 2.0).seq == 1
    send_item(link, 2, items[2])  # out of sequence: dropped, item 1 asked for again
    again = link.wait("MISSION_REQUEST_INT", 2.0)
    assert again is not None and again.seq == 1
    send_item(link, 1, items[1], kind=m.MAV_MISSION_TYPE_FENCE)  # the wrong plan type ends the upload
    ack = link.wait("MISSION_ACK", 2.0)
    assert ack.type == m.MAV_MISSION_ERROR
    assert not link.vehicle.missions.busy and download(link)[0].count == 0


def test_stray_items_and_requests_are_refused_or_ignored(link):
    send_item(link, 0, wp(link, 10, 0, 10))
    assert link.wait("STATUSTEXT", 1.0, lambda t: "partner id mismatch" in t.text) is not None  # no partner yet
    assert upload(link, [wp(link, 10, 0, 10), wp(link, 20, 0, 10)])[0].type == ACCEPTED
    send_item(link, 1, wp(link, 20, 0, 10))  # the last item again: our ACK was lost, say it again
    assert link.wait("MISSION_ACK", 1.0).type == ACCEPTED
    send_item(link, 0, wp(link, 10, 0, 10))
    ack = link.wait("MISSION_ACK", 1.0)
    assert ack.type == m.MAV_MISSION_ERROR and any("No transfer" in t for t in texts(link))
    link.mav.mission_request_list_send(1, 1, 0)
    assert link.wait("MISSION_COUNT", 1.0).count == 2
    link.mav.mission_request_int_send(1, 1, 1, 0)  # item 0 was never asked for
    assert link.wait("MISSION_ACK", 1.0).type == m.MAV_MISSION_ERROR
    assert any("unexpected" in t for t in texts(link))


def _answer_to(link, sock, parser, msg_type, ticks=50):
    """Step the vehicle until ``sock`` receives a ``msg_type`` (None if it does not within ``ticks``)."""
    for _ in range(ticks):
        link.step()
        while True:
            try:
                data = sock.recv(4096)
            except BlockingIOError:
                break
            for msg in parser.parse_buffer(data) or []:
                if msg.get_type() == msg_type:
                    return msg
    return None


def test_an_upload_on_another_link_runs_beside_the_first(link):
    other_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    other_sock.bind(("127.0.0.1", 0))
    other_sock.setblocking(False)
    other = mavutil.mavlink.MAVLink(None, srcSystem=254, srcComponent=190)
    try:
        link.drain()
        link.mav.mission_count_send(1, 1, 2, 0)
        assert link.wait("MISSION_REQUEST_INT", 2.0).seq == 0
        other_sock.sendto(other.mission_count_encode(1, 1, 3, 0).pack(other), link.vehicle.address)
        answer = _answer_to(link, other_sock, other, "MISSION_REQUEST_INT")
        assert answer is not None and answer.seq == 0 and answer.target_system == 254  # its own transfer
        # the first partner's upload goes on undisturbed
        send_item(link, 0, wp(link, 10, 0, 10))
        assert link.wait("MISSION_REQUEST_INT", 2.0, lambda r: r.target_system == 255).seq == 1
        send_item(link, 1, wp(link, 20, 0, 10))
        assert link.wait("MISSION_ACK", 2.0).type == ACCEPTED
        assert link.vehicle.missions.store.count(0) == 2
    finally:
        other_sock.close()


def test_a_second_partner_on_the_same_link_is_refused_during_an_upload(link):
    link.drain()
    link.mav.mission_count_send(1, 1, 2, 0)
    assert link.wait("MISSION_REQUEST_INT", 2.0).seq == 0
    other = mavutil.mavlink.MAVLink(None, srcSystem=254, srcComponent=190)
    link.client.write(other.mission_count_encode(1, 1, 3, 0).pack(other))
    answer = link.wait("MISSION_ACK", 2.0, lambda a: a.target_system == 254)
    assert answer is not None and answer.type == m.MAV_MISSION_ERROR
    send_item(link, 0, wp(link, 10, 0, 10))
    assert link.wait("MISSION_REQUEST_INT", 2.0, lambda r: r.target_system == 255).seq == 1


def test_malformed_mission_messages_do_not_stop_the_vehicle(link):
    good = link.mav.mission_item_int_encode(1, 1, 0, GLOBAL_REL_INT, 16, 0, 1, 0, 0, 0, 0, 0, 0, 10, 0).pack(link.mav)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.sendto(good[:20], link.vehicle.address)  # truncated
        s.sendto(b"\xfd" + bytes(range(60)), link.vehicle.address)  # garbage with a MAVLink 2 start byte
        link.mav.mission_count_send(1, 1, 1, 0)
        assert link.wait("MISSION_REQUEST_INT", 2.0) is not None
        frame, waypoint = m.MAV_FRAME_GLOBAL_RELATIVE_ALT, m.MAV_CMD_NAV_WAYPOINT
        link.mav.mission_item_send(1, 1, 0, frame, waypoint, 0, 1, 0, 0, 0, 0, math.nan, 1.0, 10.0, 0)  # NaN lat
        assert link.wait("MISSION_ACK", 2.0).type == m.MAV_MISSION_INVALID_PARAM5_X
    assert link.wait("HEARTBEAT", 2.0) is not None


# --- resends and timeouts ------------------------------------------------------------------------------------


def test_a_dropped_request_is_sent_again_and_a_silent_partner_times_out(link):
    items = [wp(link, 10, 0, 10), wp(link, 20, 0, 10)]
    link.drain()
    link.mav.mission_count_send(1, 1, 2, 0)
    first = link.wait("MISSION_REQUEST_INT", 2.0)
    assert first.seq == 0  # "lost": not answered
    again = link.wait("MISSION_REQUEST_INT", 2.0)
    assert again is not None and again.seq == 0
    send_item(link, 0, items[0])
    assert link.wait("MISSION_REQUEST_INT", 2.0).seq == 1
    requests = link.collect("MISSION_REQUEST_INT", 6.0)  # never answered
    assert len(requests) >= 5 and all(r.seq == 1 for r in requests)
    assert "Operation timeout" in texts(link)
    assert not link.vehicle.missions.busy and download(link)[0].count == 0
    assert upload(link, items)[0].type == ACCEPTED


# --- fences and feasibility ----------------------------------------------------------------------------------


def test_an_uploaded_fence_restricts_the_vehicle(link):
    square = [
        wp(link, n, e, 0, m.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, (4.0, 0, 0, 0))
        for n, e in [(-40, -40), (-40, 40), (40, 40), (40, -40)]
    ]
    no_go = [wp(link, 20, 20, 0, m.MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION, (8.0, 0, 0, 0))]
    assert upload(link, square + no_go, kind=m.MAV_MISSION_TYPE_FENCE)[0].type == ACCEPTED
    # a mission leaving the fence is stored but not valid, and cannot start
    outside = [wp(link, 0, 0, 10, m.MAV_CMD_NAV_TAKEOFF), wp(link, 10, 0, 10), wp(link, 60, 0, 10)]
    ack, _ = upload(link, outside)
    assert ack.type == ACCEPTED
    assert link.wait("STATUSTEXT", 1.0, lambda t: t.text == "Geofence violation for waypoint 3") is not None
    current = mission_current(link, lambda c: c.total == 3)
    assert current.mission_state == m.MISSION_STATE_NO_MISSION
    assert link.command(m.MAV_CMD_MISSION_START, 0, 0).result == DENIED
    assert "Mission start denied! No valid mission" in texts(link)
    assert not link.vehicle.sim.armed
    # commands too: a reposition into the exclusion circle is refused
    take_off(link, 8.0)
    home = home_of(link)
    lat, lon = offset_position(home.lat_deg, home.lon_deg, 20.0, 20.0)
    ack = link.command(m.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, lat, lon, math.nan)
    assert ack.result == DENIED and any("exclusion fence" in t for t in texts(link))
    # and flying out of the inclusion square is a breach: GF_ACTION 2 holds inside
    link.vehicle.navigator.fly_leg(70.0, 0.0, -8.0)
    text = link.wait("STATUSTEXT", 30.0, lambda t: "Geofence breached" in t.text)
    assert text is not None and any(
        "Geofence breached (outside the uploaded inclusion fence)" in t for t in texts(link)
    )
    link.run_for(8.0)
    s = link.vehicle.sim.state()
    assert s.north_m < 42.0 and link.vehicle.mode.name == "HOLD"


# --- flying a mission ----------------------------------------------------------------------------------------


def collect_reached(link, until, timeout_s):
    """Step until ``until(vehicle)``; the MISSION_ITEM_REACHED sequence numbers (repeats dropped) with the
    vehicle's position when each first arrived, and every STATUSTEXT."""
    reached: list[int] = []
    where: dict[int, tuple[float, float, float]] = {}
    said: list[str] = []
    for _ in range(math.ceil(timeout_s / link.vehicle.tick_s)):
        link.step()
        while (msg := link.client.recv_match(blocking=False)) is not None:
            if msg.get_type() == "MISSION_ITEM_REACHED" and (not reached or reached[-1] != msg.seq):
                reached.append(msg.seq)
                s = link.vehicle.sim.state()
                where[msg.seq] = (s.north_m, s.east_m, s.alt_agl_m)
            elif msg.get_type() == "STATUSTEXT":
                said.append(msg.text)
        if until(link.vehicle):
            break
    return reached, where, said


def test_a_mission_is_flown_item_by_item_and_lands(link):
    items = [
        wp(link, 0, 0, 10, m.MAV_CMD_NAV_TAKEOFF),
        wp(link, 30, 0, 10),
        do(m.MAV_CMD_DO_CHANGE_SPEED, 1, 8.0, -1),
        wp(link, 30, 30, 14, params=(2.0, 1.0, 0.0, math.nan)),  # hold 2 s, within 1 m
        do(m.MAV_CMD_DO_GRIPPER, 1, 0),  # release
        wp(link, 0, 30, 12),
        wp(link, 0, 30, 0, m.MAV_CMD_NAV_LAND),
    ]
    assert upload(link, items)[0].type == ACCEPTED
    ack = link.command(m.MAV_CMD_MISSION_START, 0, 0)
    assert ack.result == ACCEPTED and link.vehicle.sim.armed  # MISSION_START arms, as in PX4
    assert link.vehicle.mode.name == "MISSION"
    reached, where, said = collect_reached(link, lambda v: not v.sim.armed, 120.0)
    assert reached == list(range(len(items)))
    for seq, (north, east, alt) in [(1, (30, 0, 10)), (3, (30, 30, 14)), (5, (0, 30, 12))]:
        n, e, a = where[seq]
        radius = 1.0 if seq == 3 else 2.0
        assert math.hypot(n - north, e - east) <= radius + 0.2 and abs(a - alt) <= 1.2, (seq, where[seq])
    assert abs(where[0][2] - 10.0) < 1.0  # the take-off climbed first
    s = link.vehicle.sim.state()
    assert s.landed and not s.armed and math.hypot(s.north_m, s.east_m - 30.0) < 3.0
    assert link.vehicle.sim.payload_released
    assert link.vehicle.navigator.cruise_speed_mps == 8.0
    assert "Mission finished, landed" in said and link.vehicle.mode.name == "HOLD"  # as PX4 since 1.14
    current = mission_current(link)
    assert current.mission_state == m.MISSION_STATE_COMPLETE and current.seq == len(items) - 1


def test_a_mission_without_a_landing_ends_in_hold_and_the_current_item_can_be_set(link):
    items = [wp(link, 15, 0, 8), wp(link, 15, 15, 8), wp(link, 0, 15, 8)]
    assert upload(link, items)[0].type == ACCEPTED
    take_off(link, 8.0)  # flying already: no take-off item needed
    mode = mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert link.command(m.MAV_CMD_DO_SET_MODE, mode, 4, 4).result == ACCEPTED  # AUTO.MISSION
    reached, _, said = collect_reached(link, lambda v: v.mode.name == "HOLD", 90.0)
    assert reached == [0, 1, 2] and "Mission finished, loitering" in said
    complete = mission_current(link)
    assert complete.mission_state == m.MISSION_STATE_COMPLETE
    # MISSION_SET_CURRENT announces the new item at once; DO_SET_MISSION_CURRENT out of range FAILS
    link.drain()
    link.mav.mission_set_current_send(1, 1, 1)
    now = link.wait("MISSION_CURRENT", 0.2)
    assert now is not None and now.seq == 1 and now.mission_state == m.MISSION_STATE_PAUSED
    assert link.command(m.MAV_CMD_DO_SET_MISSION_CURRENT, 7).result == FAILED
    assert link.command(m.MAV_CMD_DO_SET_MODE, mode, 4, 4).result == ACCEPTED
    reached, where, _ = collect_reached(link, lambda v: v.mode.name == "HOLD", 60.0)
    assert reached == [1, 2]
    assert math.hypot(where[1][0] - 15.0, where[1][1] - 15.0) < 2.2  # flew back to item 1, then on
    assert math.hypot(where[2][0], where[2][1] - 15.0) < 2.2


def test_mission_mode_needs_a_valid_mission(link):
    mode = mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert link.command(m.MAV_CMD_DO_SET_MODE, mode, 4, 4).result == DENIED
    assert any("no mission" in t for t in texts(link))
    assert link.command(m.MAV_CMD_MISSION_START, 0, 0).result == DENIED
    assert upload(link, [wp(link, 10, 0, 8)])[0].type == ACCEPTED
    assert link.command(m.MAV_CMD_MISSION_START, 3, 0).result == DENIED  # first item out of range
    assert link.command(m.MAV_CMD_DO_SET_MODE, mode, 4, 4).result == ACCEPTED  # disarmed: only the label
    assert link.vehicle.mode.name == "MISSION" and not link.vehicle.sim.armed
    assert link.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == ACCEPTED  # arming in Mission starts it
    reached, where, _ = collect_reached(link, lambda v: v.mode.name == "HOLD", 60.0)
    assert reached == [0] and where[0][2] == pytest.approx(8.0, abs=1.2)


def test_jumps_loiters_delays_and_the_servo_release(link):
    items = [
        wp(link, 0, 0, 8, m.MAV_CMD_NAV_TAKEOFF),
        wp(link, 12, 0, 8),
        wp(link, 12, 12, 8),
        do(m.MAV_CMD_DO_JUMP, 1, 1),  # back to item 1, once
        wp(link, 0, 12, 8, m.MAV_CMD_NAV_LOITER_TIME, params=(4.0, 0.0, 0.0, 0.0)),
        do(m.MAV_CMD_NAV_DELAY, 2.0, -1, -1, -1),
        do(m.MAV_CMD_DO_SET_SERVO, 9, 1900),  # PWM above 1700 releases the payload
        wp(link, 0, 0, 8, m.MAV_CMD_NAV_LOITER_UNLIM),
        wp(link, 5, 5, 8),
    ]
    assert upload(link, items)[0].type == ACCEPTED
    assert link.command(m.MAV_CMD_MISSION_START, 0, 0).result == ACCEPTED
    times: dict[int, float] = {}

    def loitering(v):
        s = v.sim.state()
        return v.missions.store.current_seq == 7 and math.hypot(s.north_m, s.east_m) < 1.0 and 7 not in times

    reached: list[int] = []
    for _ in range(round(90.0 / link.vehicle.tick_s)):
        link.step()
        while (msg := link.client.recv_match(blocking=False)) is not None:
            if msg.get_type() == "MISSION_ITEM_REACHED" and (not reached or reached[-1] != msg.seq):
                reached.append(msg.seq)
                times[msg.seq] = link.vehicle.sim.time_s
        if loitering(link.vehicle):
            break
    assert reached == [0, 1, 2, 1, 2, 3, 4, 5, 6]  # the jump repeated items 1-2 once; then on to the loiter
    assert times[5] - times[4] >= 2.0  # the delay
    assert link.vehicle.sim.payload_released
    link.run_for(10.0)  # an unlimited loiter is never "reached": the vehicle stays
    assert link.vehicle.missions.store.current_seq == 7 and link.vehicle.mode.name == "MISSION"
    link.drain()
    link.mav.mission_set_current_send(1, 1, 8)  # move it on
    rest, _, said = collect_reached(link, lambda v: v.mode.name == "HOLD", 30.0)
    assert rest == [8] and "Mission finished, loitering" in said
