"""The ``.tlog`` writer: pymavlink's log reader reads back every frame with its stamp, stamps never go back, a log
cut mid-record by a kill is mended before more is appended, and threads writing at once never interleave bytes.
Also the frame taps of the vehicle and of the client that feed it."""

from __future__ import annotations

import asyncio
import threading
from pathlib import Path
from typing import Any

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common

from flight.mavlink import MavlinkVehicle
from flight.sim import Simulator
from flight.tlog import STAMP, TlogWriter, complete_records, frame_length, simulated_clock
from flight.vehicle import VehicleClient
from tests.tlogs import read_tlog
from tests.waiting import wait_for, wait_for_async

MAV = common.MAVLink(None, srcSystem=1, srcComponent=1)


def heartbeat(n: int = 0) -> bytes:
    frame: bytes = common.MAVLink_heartbeat_message(2, 12, 0, n, 3, 3).pack(MAV)
    return frame


class Clock:
    def __init__(self, *times: float) -> None:
        self.times = list(times)

    def __call__(self) -> float:
        return self.times.pop(0)


def test_frames_come_back_in_order_with_their_stamps_which_never_go_back(tmp_path: Path) -> None:
    path = tmp_path / "a.tlog"
    log = TlogWriter(path, clock=Clock(100.0, 101.5, 99.0, 102.25))  # the wall clock stepped back once
    for n in range(4):
        log(heartbeat(n))
    log.close()
    log(heartbeat(9))  # after close: ignored
    msgs = read_tlog(path)
    assert [m.custom_mode for m in msgs] == [0, 1, 2, 3]
    assert [m._timestamp for m in msgs] == [100.0, 101.5, 101.5, 102.25]


def test_a_log_cut_mid_record_is_mended_and_appended_to(tmp_path: Path) -> None:
    record = STAMP.size + len(heartbeat())
    for cut in (1, 7, 8, 9, record - 1):  # inside the last record's stamp, just after it, inside its frame
        path = tmp_path / f"cut-{cut}.tlog"
        log = TlogWriter(path, clock=Clock(1.0, 2.0, 3.0))
        for n in range(3):
            log(heartbeat(n))
        log.close()
        with path.open("r+b") as f:
            f.truncate(3 * record - cut)
        assert complete_records(path) == (2 * record, 2_000_000)
        again = TlogWriter(path, clock=Clock(1.5))  # earlier than the last stamp kept: stamped with it
        assert again.last_us == 2_000_000
        again(heartbeat(7))
        again.close()
        msgs = read_tlog(path)
        assert [m.custom_mode for m in msgs] == [0, 1, 7] and msgs[-1]._timestamp == 2.0


def test_garbage_in_a_log_is_cut_off_at_the_first_record_that_is_not_one(tmp_path: Path) -> None:
    path = tmp_path / "a.tlog"
    path.write_bytes(STAMP.pack(5) + heartbeat(1) + STAMP.pack(6) + b"\x00" * 40)
    TlogWriter(path).close()
    assert path.read_bytes() == STAMP.pack(5) + heartbeat(1)


def test_frame_lengths_of_both_versions_and_signed_frames() -> None:
    signed = common.MAVLink(None, srcSystem=1, srcComponent=1)
    signed.signing.secret_key = bytes(32)
    signed.signing.sign_outgoing = True
    for mav in (MAV, signed):
        frame = common.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3).pack(mav)
        assert frame_length(frame) == len(frame)
    v1 = mavutil.mavlink.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3)
    assert frame_length(bytes([0xFE, 9, 0])) == 17 and v1 is not None
    assert frame_length(b"\x00\x01\x02") is None and frame_length(b"\xfd") is None


def test_threads_writing_at_once_never_mix_their_frames(tmp_path: Path) -> None:
    path = tmp_path / "a.tlog"
    log = TlogWriter(path, flush_s=0.0)
    per_thread = 2000

    def write(n: int) -> None:
        for _ in range(per_thread):
            log(heartbeat(n))

    threads = [threading.Thread(target=write, args=(n,)) for n in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    log.close()
    msgs = read_tlog(path)
    assert len(msgs) == 4 * per_thread
    assert sorted({m.custom_mode for m in msgs}) == [0, 1, 2, 3]
    stamps = [m._timestamp for m in msgs]
    assert stamps == sorted(stamps)


def test_a_simulated_clock_runs_with_the_simulation_and_starts_after_the_log() -> None:
    sim_t = [50.0]
    later = 4_000_000_000_000_000  # 2096, surely after now
    clock = simulated_clock(lambda: sim_t[0], not_before_us=later)
    assert clock() == later / 1e6
    sim_t[0] = 62.5
    assert clock() == pytest.approx(later / 1e6 + 12.5)


def test_the_vehicle_taps_what_it_sends_and_takes_in_and_a_failing_tap_does_not_stop_it(tmp_path: Path) -> None:
    frames: list[bytes] = []

    def broken(frame: bytes) -> None:
        raise OSError("disk full")

    with MavlinkVehicle(Simulator(), gcs=None, api=None) as vehicle:
        vehicle.on_wire.extend([broken, frames.append])
        gcs = mavutil.mavlink_connection(f"udpout:{vehicle.address[0]}:{vehicle.address[1]}", source_system=255)
        try:
            gcs.mav.heartbeat_send(6, 8, 0, 0, 0)

            def heard() -> list[Any]:
                vehicle.step()
                return vehicle.peers

            wait_for(heard, 5.0, what="the vehicle to hear the heartbeat")
            vehicle.run_for(1.0)
        finally:
            gcs.close()
        assert vehicle.sim.time_s > 1.0 and any("disk full" in e for e in vehicle.tick_errors)
    sources = {(f[5], f[6]) for f in frames}  # MAVLink 2: system and component ids at bytes 5 and 6
    assert sources == {(1, 1), (255, 0)}
    assert all(frame_length(f) == len(f) for f in frames)


def test_the_client_taps_what_it_sends_and_hears_from_its_vehicle(tmp_path: Path) -> None:
    path = tmp_path / "client.tlog"

    async def talk(address: str) -> None:
        client = await VehicleClient.connect(address, timeout_s=10.0)
        client.on_wire(log)
        try:
            await wait_for_async(lambda: log.frames > 20, 10.0, what="frames on the client's link")
            assert (await client.set_stream_rates({"GLOBAL_POSITION_INT": 20.0})) == {33: True}
        finally:
            client.close()

    log = TlogWriter(path, flush_s=0.0)
    with MavlinkVehicle(Simulator(), gcs=None, api=None) as vehicle:
        vehicle.start(speed=None)
        asyncio.run(talk(f"{vehicle.address[0]}:{vehicle.address[1]}"))
    log.close()
    msgs = read_tlog(path)
    assert {m.get_srcSystem() for m in msgs} == {1, 255}
    sent = [m for m in msgs if m.get_srcSystem() == 255]
    assert {m.command for m in sent if m.get_type() == "COMMAND_LONG"} == {common.MAV_CMD_SET_MESSAGE_INTERVAL}
    assert any(m.get_type() == "COMMAND_ACK" and m.get_srcSystem() == 1 for m in msgs)
