"""The streamed messages packed by :class:`~flight.mavlink.telemetry.WireCodec` are byte for byte pymavlink's."""

import random

import pytest
from pymavlink.dialects.v20 import common as mavlink2

from flight.mavlink import MavlinkVehicle
from flight.mavlink.telemetry import (
    ATTITUDE,
    AUTOPILOT_VERSION,
    BATTERY_STATUS,
    EXTENDED_SYS_STATE,
    GLOBAL_POSITION_INT,
    GPS_RAW_INT,
    HEARTBEAT,
    HOME_POSITION,
    LOCAL_POSITION_NED,
    MISSION_CURRENT,
    SYS_STATUS,
)
from flight.sim import Simulator

CODECS = [
    HEARTBEAT,
    SYS_STATUS,
    BATTERY_STATUS,
    ATTITUDE,
    GLOBAL_POSITION_INT,
    LOCAL_POSITION_NED,
    GPS_RAW_INT,
    EXTENDED_SYS_STATE,
    HOME_POSITION,
    AUTOPILOT_VERSION,
    MISSION_CURRENT,
]

_INT_RANGES = {"B": (0, 255), "b": (-128, 127), "H": (0, 65535), "h": (-32768, 32767)}
_INT_RANGES |= {"I": (0, 2**32 - 1), "i": (-(2**31), 2**31 - 1), "Q": (0, 2**64 - 1), "q": (-(2**63), 2**63 - 1)}


def _value(fmt_char, rng, zero):
    if fmt_char in "fd":
        return 0.0 if zero else rng.uniform(-1e4, 1e4)
    lo, hi = _INT_RANGES[fmt_char]
    return 0 if zero else rng.randint(lo, hi)


def random_fields(cls, rng, zero_from=None):
    """Fields for ``cls`` in constructor order; from index ``zero_from`` on, zeros (to exercise trimming)."""
    fmt = {name: t for name, t in zip(cls.fieldnames, _field_formats(cls), strict=True)}
    out: list[object] = []
    for i, name in enumerate(cls.fieldnames):
        zero = zero_from is not None and i >= zero_from
        char, count = fmt[name]
        if char == "s":
            out.append(b"" if zero else bytes(rng.randrange(32, 127) for _ in range(rng.randint(0, count))))
        elif count > 1:
            out.append([_value(char, rng, zero) for _ in range(count)])
        else:
            out.append(_value(char, rng, zero))
    return tuple(out)


def _field_formats(cls):
    """(struct character, count) per field, in constructor order: ``native_format`` has one character per field
    in wire order, ``array_lengths`` the count of an array (``c`` is a char array, packed as bytes)."""
    chars = cls.native_format.decode()[1:]
    wire = {}
    for name, char, count in zip(cls.ordered_fieldnames, chars, cls.array_lengths, strict=True):
        wire[name] = ("s" if char == "c" else char, max(count, 1))
    return [wire[name] for name in cls.fieldnames]


def pymavlink_bytes(codec, mav, fields):
    return bytes(codec.cls(*fields).pack(mav))


@pytest.mark.parametrize("codec", CODECS, ids=lambda c: c.cls.msgname)
def test_codec_packs_what_pymavlink_packs(codec):
    rng = random.Random(codec.cls.id)
    mav = mavlink2.MAVLink(None, srcSystem=7, srcComponent=190)
    n = len(codec.cls.fieldnames)
    for trial in range(60):
        mav.seq = rng.randrange(256)
        fields = random_fields(codec.cls, rng, zero_from=rng.choice([None, 0, n // 2, n - 1]))
        assert codec.pack(mav, fields) == pymavlink_bytes(codec, mav, fields), (trial, fields)
        # The extensions left out take the message's defaults, as the encode functions' defaults do.
        base = fields[: codec._required]
        assert codec.pack(mav, base) == pymavlink_bytes(codec, mav, base)


def test_codec_message_is_the_encode_functions_message():
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    msg = ATTITUDE.message((1234, 0.1, -0.2, 3.0, 0.01, 0.02, -0.03))
    ref = mav.attitude_encode(1234, 0.1, -0.2, 3.0, 0.01, 0.02, -0.03)
    assert type(msg) is type(ref) and msg.to_dict() == ref.to_dict()
    assert MISSION_CURRENT.message((3, 5, 2, 1)).to_dict() == mav.mission_current_encode(3, 5, 2, 1).to_dict()


def test_codec_rejects_too_few_fields():
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    with pytest.raises(TypeError):
        ATTITUDE.pack(mav, (1, 0.0))


def test_a_signed_link_takes_pymavlink_s_path():
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    mav.signing.secret_key = bytes(range(32))
    mav.signing.sign_outgoing = True
    mav.signing.timestamp = 1000
    fields = (1234, 0.1, -0.2, 3.0, 0.01, 0.02, -0.03)
    frame = ATTITUDE.pack(mav, fields)
    assert frame[2] & mavlink2.MAVLINK_IFLAG_SIGNED and len(frame) == 10 + 28 + 2 + 13
    assert mav.signing.timestamp == 1001


def test_every_message_the_vehicle_builds_packs_as_pymavlink_packs_it():
    sim = Simulator(seed=2)
    with MavlinkVehicle(sim, gcs=None, api=None) as vehicle:
        vehicle.navigator.arm()
        vehicle.navigator.takeoff(5.0)
        for _ in range(3):
            vehicle.run_for(1.3)
            for codec, fields in vehicle._builders.values():
                values = fields()
                assert codec.pack(vehicle._mav, values) == pymavlink_bytes(codec, vehicle._mav, values)
