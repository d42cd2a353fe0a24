"""Attacks on MAVLink 2 signing: each is refused and counted, and the vehicle's own ground station still flies it."""

import math
import os
import stat

from pymavlink.dialects.v20 import common as mavlink2

from flight.mavlink import MavlinkVehicle
from flight.signing import new_key
from flight.sim import Simulator
from tests.flight.mavlink.conftest import ACCEPTED, take_off

m = mavlink2
ARM = m.MAV_CMD_COMPONENT_ARM_DISARM


def armed(vehicle):
    """Whether it is armed (through a function, so that type checkers do not narrow it across steps)."""
    return vehicle.sim.armed


def _refused(vehicle, reason):
    return vehicle.security()[reason]


def test_unsigned_commands_are_refused_and_counted(signed, attackers):
    stranger = attackers(signed.vehicle.address)
    stranger.command(ARM, 1)
    stranger.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, 320.0)
    signed.run_for(0.5)
    assert not armed(signed.vehicle)
    assert _refused(signed.vehicle, "unsigned") >= 2
    assert stranger.address not in signed.vehicle.peers  # a refused message teaches no peer
    assert signed.command(ARM, 1).result == ACCEPTED  # the signed ground station still commands it
    assert armed(signed.vehicle)


def test_a_frame_signed_with_another_key_is_refused(signed, attackers):
    stranger = attackers(signed.vehicle.address, key=new_key())
    stranger.command(ARM, 1)
    signed.run_for(0.5)
    assert not armed(signed.vehicle) and _refused(signed.vehicle, "bad_signature") == 1


def test_a_replayed_signed_command_is_refused(signed, attackers):
    captured = signed.mav.command_long_encode(1, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(signed.mav)
    signed.mav.seq += 1
    signed.client.write(captured)
    signed.run_for(0.2)
    assert armed(signed.vehicle)
    assert signed.command(ARM, 0).result == ACCEPTED and not armed(signed.vehicle)
    stranger = attackers(signed.vehicle.address)
    stranger.raw(captured)  # the recorded arm, from another socket
    signed.client.write(captured)  # and from the ground station's own
    signed.run_for(0.5)
    assert not armed(signed.vehicle) and _refused(signed.vehicle, "replayed") == 2


def _recrc(buf):
    """A MAVLink 2 frame's CRC made right again after its payload was changed (as a tamperer would)."""
    buf = bytearray(buf)
    length, msg_id = buf[1], buf[7] | buf[8] << 8 | buf[9] << 16
    crc = m.x25crc(bytes(buf[1 : 10 + length]))
    crc.accumulate(bytes([m.mavlink_map[msg_id].crc_extra]))
    buf[10 + length : 12 + length] = crc.crc.to_bytes(2, "little")
    return bytes(buf)


def test_a_tampered_signed_frame_is_refused(signed, attackers):
    land = bytearray(signed.mav.command_long_encode(1, 1, ARM, 0, 1, 0, 0, 0, 0, 0, 0).pack(signed.mav))
    signed.mav.seq += 1
    tampered = bytearray(land)
    tampered[14] ^= 0x01  # a bit of param1's float: arm becomes something else
    stranger = attackers(signed.vehicle.address)
    stranger.raw(tampered)  # the CRC no longer matches: not even a message
    stranger.raw(_recrc(tampered))  # the CRC mended: the signature does not match
    signed.run_for(0.5)
    assert not armed(signed.vehicle)
    assert signed.vehicle.stats.rx_bad_chunks >= 1 and _refused(signed.vehicle, "bad_signature") == 1


def test_setup_signing_from_a_stranger_cannot_change_the_key(signed, attackers):
    stranger = attackers(signed.vehicle.address)
    stranger.send(stranger.mav.setup_signing_encode(1, 1, list(bytes(32)), 0))  # "signing off", unsigned
    stranger.send(stranger.mav.setup_signing_encode(1, 1, list(new_key()), 0))  # or their own key
    signed.run_for(0.5)
    assert signed.vehicle.guard.signer.key == signed.key and _refused(signed.vehicle, "unsigned") == 2


def test_the_key_cannot_change_in_the_air_even_signed(signed):
    take_off(signed, 5.0)
    signed.mav.setup_signing_send(1, 1, list(new_key()), 0)
    signed.run_for(0.5)
    assert signed.vehicle.guard.signer.key == signed.key and _refused(signed.vehicle, "refused_setup_signing") == 1


def test_signing_required_without_a_key_refuses_commands_until_one_is_provisioned(attackers, tmp_path):
    store = tmp_path / "state" / "mavlink" / "mavlink-signing-key.bin"
    with MavlinkVehicle(Simulator(seed=1), gcs=None, api=None, require_signing=True, key_store=store) as vehicle:
        gcs = attackers(vehicle.address, system_id=255)
        gcs.command(ARM, 1)
        vehicle.run_for(0.2)
        assert not armed(vehicle) and _refused(vehicle, "no_key") == 1  # not "accept all"
        key = new_key()
        gcs.send(gcs.mav.setup_signing_encode(1, 1, list(key), 0))  # provisioning, on the ground
        vehicle.run_for(0.2)
        assert vehicle.guard.signer.key == key
        assert stat.S_IMODE(os.stat(store).st_mode) == 0o600 and stat.S_IMODE(os.stat(store.parent).st_mode) == 0o700
        signer = attackers(vehicle.address, key=key)
        signer.command(ARM, 1)
        vehicle.run_for(0.2)
        assert armed(vehicle)
    with MavlinkVehicle(Simulator(seed=1), gcs=None, api=None, key_store=store) as again:
        assert again.guard.signer.key == key  # kept as PX4 keeps it


def test_the_vehicle_signs_what_it_sends(signed):
    beat = signed.wait("HEARTBEAT", 2.0)
    assert beat is not None and beat.get_signed()  # pymavlink checked the signature with the key


def test_a_forged_frame_from_the_future_cannot_lock_the_ground_station_out(signed, attackers):
    """pymavlink records a stream's timestamp before it compares signatures; the guard compares first."""
    forger = attackers(signed.vehicle.address, system_id=255, key=new_key(), link_id=1)  # the GCS's own stream
    forger.mav.signing.timestamp += 10**12
    forger.command(ARM, 1)
    signed.run_for(0.2)
    assert _refused(signed.vehicle, "bad_signature") == 1 and not armed(signed.vehicle)
    assert signed.command(ARM, 1).result == ACCEPTED  # its next, honest, timestamp is still taken


def test_a_bad_key_file_is_a_clear_error(tmp_path, capsys):
    from flight.cli import main

    paths = []
    for name, data in (("short", b"abc"), ("not-hex", b"z" * 64), ("long", b"0" * 66)):
        paths.append(tmp_path / name)
        paths[-1].write_bytes(data)
    paths += [tmp_path / "missing", tmp_path]  # no file; a directory
    for path in paths:
        assert main(["--signing-key", str(path), "--bind", "127.0.0.1:0"]) == 2
        err = capsys.readouterr().err
        assert str(path) in err and "Traceback" not in err and len(err.splitlines()) == 1
