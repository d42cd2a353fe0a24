"""Fuzzing the vehicle's UDP endpoint: random bytes, truncated and corrupted frames, valid messages with absurd fields.

Why: the vehicle listens on a UDP port that anything on the network can write to. Whatever arrives, it must keep
flying, drop what is not MAVLink (and count it), and carry on answering its clients. Hypothesis generates the
datagrams; each one is sent from a raw socket and followed by one vehicle tick in lockstep, so the effect of every
datagram is known exactly:

* a datagram holding no valid MAVLink message adds one to ``stats.rx_dropped``, is not a message and does not make its
  sender a peer;
* a datagram holding valid messages adds them to ``stats.rx_messages`` and leaves ``rx_dropped`` alone: the vehicle
  counts a message whose handler raised as dropped, so an unchanged ``rx_dropped`` is also the proof that no handler
  crashed on the absurd values;
* after every datagram the simulated state is finite and every parameter within its range; after the barrage the
  vehicle answers a normal client (PING, REQUEST_MESSAGE, PARAM_REQUEST_READ) correctly.

"Valid" is what a fresh robust pymavlink parser makes of the datagram (:func:`valid_messages`), the same definition
the vehicle uses; the strategies also assert their own intent (a truncated frame never parses, a corrupted CRC never
passes). The last test throws a mixed burst at the vehicle running free on its thread, as in real use.
"""

from __future__ import annotations

import math
import socket
import time
from dataclasses import dataclass
from typing import Any, Literal

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from flight.mavlink import PARAMS, MavlinkVehicle
from flight.mavlink.commands import HANDLERS
from flight.mavlink.mission import MESSAGES as MISSION_MESSAGES
from flight.mavlink.mission_service import MISSION_COMMANDS
from flight.sim import Simulator
from tests.waiting import wait_for

from .conftest import ACCEPTED

m = mavutil.mavlink

HANDLED = (
    "HEARTBEAT",
    "PING",
    "PARAM_REQUEST_READ",
    "PARAM_REQUEST_LIST",
    "PARAM_SET",
    "COMMAND_INT",
    "COMMAND_LONG",
    "SET_POSITION_TARGET_LOCAL_NED",
    "SET_POSITION_TARGET_GLOBAL_INT",
    *sorted(mavlink2.mavlink_map[msg_id].msgname for msg_id in MISSION_MESSAGES),
)
"""Every message type the vehicle acts on (HEARTBEAT only makes its sender a peer)."""
MESSAGE_CLASSES = {cls.msgname: cls for cls in mavlink2.mavlink_map.values() if cls.msgname in HANDLED}
assert set(MESSAGE_CLASSES) == set(HANDLED)

FLOAT32_MAX = 3.4028234663852886e38
INT_RANGES = {
    "int8_t": (-(2**7), 2**7 - 1),
    "uint8_t": (0, 2**8 - 1),
    "int16_t": (-(2**15), 2**15 - 1),
    "uint16_t": (0, 2**16 - 1),
    "int32_t": (-(2**31), 2**31 - 1),
    "uint32_t": (0, 2**32 - 1),
    "int64_t": (-(2**63), 2**63 - 1),
    "uint64_t": (0, 2**64 - 1),
}
COMMANDS = tuple(sorted(set(HANDLERS) | set(MISSION_COMMANDS)))
"""Every command the vehicle carries out (the rest are answered UNSUPPORTED)."""
EXAMPLES = 200
"""Datagrams per barrage of garbage, truncated or corrupted frames."""
PER_TYPE = 40
"""Datagrams per message type (and per supported command) with absurd field values."""


# -- strategies ---------------------------------------------------------------------------------------------------


def absurd_floats(width: Literal[32, 64] = 32) -> st.SearchStrategy[float]:
    """Any float of the wire width, with the edge cases (NaN, ±inf, ±max, tiny) and small whole numbers (modes,
    enums, flags, ids) drawn often, and now and then a coordinate near home."""
    big = FLOAT32_MAX if width == 32 else 1.7976931348623157e308
    edges = st.sampled_from([math.nan, math.inf, -math.inf, big, -big, 0.0, -0.0, 1e-45, 21196.0, 21.4135, 39.8935])
    return st.one_of(edges, st.integers(-3, 16).map(float), st.floats(width=width))


def absurd_ints(kind: str) -> st.SearchStrategy[int]:
    lo, hi = INT_RANGES[kind]
    return st.one_of(st.sampled_from([lo, hi, 0, 1, hi // 2]), st.integers(lo, hi))


def field_values(kind: str, length: int) -> st.SearchStrategy[Any]:
    """A value of one MAVLink field (``length`` > 0: an array; char arrays are bytes)."""
    if kind == "char":
        return st.binary(max_size=max(length, 1))
    one: st.SearchStrategy[Any]
    if kind == "float":
        one = absurd_floats(32)
    elif kind == "double":
        one = absurd_floats(64)
    else:
        one = absurd_ints(kind)
    return st.lists(one, min_size=length, max_size=length) if length else one


NEAR_HOME_E7 = {"x": 214_133_000, "lat_int": 214_133_000, "y": 398_933_000, "lon_int": 398_933_000}
"""Integer coordinates (degE7) around which some positions are drawn, so that some of them are inside the fence."""


def targeted(name: str, kind: str, command: int | None) -> st.SearchStrategy[Any] | None:
    """Fields worth steering towards values the vehicle acts on (a random target or command is mostly ignored)."""
    if name in ("target_system", "target_component"):
        return st.one_of(st.sampled_from([0, 1, 1, 1]), absurd_ints(kind))
    if name == "command":
        if command is not None:
            return st.just(command)
        return st.one_of(st.sampled_from(COMMANDS), absurd_ints(kind))
    if name == "param_id":
        return st.one_of(st.sampled_from([p.name.encode() for p in PARAMS]), st.binary(max_size=16))
    if name in ("param1", "param2", "param3") and kind == "float":  # modes, flags, ids: mostly small numbers
        return st.one_of(st.integers(-1, 8).map(float), absurd_floats())
    if name in NEAR_HOME_E7 and kind == "int32_t":
        centre = NEAR_HOME_E7[name]
        return st.one_of(st.integers(centre - 20_000, centre + 20_000), absurd_ints(kind))
    return None


@st.composite
def absurd_messages(draw: st.DrawFn, names: tuple[str, ...] = HANDLED, command: int | None = None) -> Any:
    """A message of one of ``names`` with every field drawn from the whole range of its wire type (a command
    message carries ``command`` when given)."""
    cls = MESSAGE_CLASSES[draw(st.sampled_from(names))]
    values = {}
    for name, kind in zip(cls.fieldnames, cls.fieldtypes, strict=True):
        length = cls.array_lengths[cls.ordered_fieldnames.index(name)]
        steered = targeted(name, kind, command)
        values[name] = draw(steered if steered is not None else field_values(kind, length))
    return cls(**values)


def pack(msg: Any, mavlink1: bool, seq: int = 0) -> bytes:
    """``msg`` on the wire as a client (system 255, component 190) would send it."""
    mav = mavlink2.MAVLink(None, srcSystem=255, srcComponent=190)
    mav.seq = seq
    return bytes(msg.pack(mav, force_mavlink1=mavlink1 and msg.id < 256))


@st.composite
def valid_frames(draw: st.DrawFn, names: tuple[str, ...] = HANDLED, command: int | None = None) -> bytes:
    """A handled message with absurd fields, as a MAVLink 1 or 2 frame."""
    return pack(draw(absurd_messages(names, command)), draw(st.booleans()), draw(st.integers(0, 255)))


@st.composite
def truncated_frames(draw: st.DrawFn) -> bytes:
    frame = draw(valid_frames())
    return frame[: draw(st.integers(1, len(frame) - 1))]


@st.composite
def corrupted_frames(draw: st.DrawFn) -> bytes:
    """A valid frame with one payload or checksum byte changed: the CRC must catch it."""
    frame = bytearray(draw(valid_frames()))
    header = 10 if frame[0] == 0xFD else 6
    at = draw(st.integers(header, len(frame) - 1))
    frame[at] ^= draw(st.integers(1, 255))
    return bytes(frame)


def garbage() -> st.SearchStrategy[bytes]:
    """Random bytes, often starting like a MAVLink frame so that the parser gets past the first byte."""
    start = st.sampled_from([b"", b"\xfd", b"\xfe", b"\xfd\x09\x00\x00", b"\xfe\x21"])
    return st.builds(lambda a, b: a + b, start, st.binary(max_size=300)).filter(bool)


# -- the oracle and the harness -----------------------------------------------------------------------------------


def valid_messages(data: bytes) -> int:
    """How many valid messages a fresh robust parser finds in ``data`` (as the vehicle parses every datagram)."""
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    try:
        msgs = parser.parse_buffer(data) or []
    except Exception:
        return 0
    return sum(1 for msg in msgs if msg.get_type() != "BAD_DATA")


@dataclass
class Counters:
    rx_datagrams: int = 0
    rx_messages: int = 0
    rx_dropped: int = 0

    @classmethod
    def of(cls, vehicle: MavlinkVehicle) -> Counters:
        s = vehicle.stats
        return cls(s.rx_datagrams, s.rx_messages, s.rx_dropped)


class Target:
    """A lockstep vehicle, a raw socket that throws datagrams at it and the running expectation of its counters."""

    def __init__(self, vehicle: MavlinkVehicle) -> None:
        self.vehicle = vehicle
        self.raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.raw.bind(("127.0.0.1", 0))
        self.raw.setblocking(False)
        self.expected = Counters.of(vehicle)
        self.thrown = 0
        self.valid_seen = 0
        """Datagrams thrown, and how many of them held valid messages."""
        self.strangers = 0
        """Datagrams from another address (another test's client still sending to a port this vehicle now has)."""
        handle = vehicle._datagram

        def datagram(data: bytes, sender: tuple[str, int]) -> None:
            before = Counters.of(vehicle)
            handle(data, sender)
            if sender != self.raw_address:
                after = Counters.of(vehicle)
                self.strangers += 1
                self.expected.rx_datagrams += 1
                self.expected.rx_messages += after.rx_messages - before.rx_messages
                self.expected.rx_dropped += after.rx_dropped - before.rx_dropped

        vehicle._datagram = datagram  # type: ignore[method-assign]

    @property
    def raw_address(self) -> tuple[str, int]:
        host, port = self.raw.getsockname()[:2]
        return str(host), int(port)

    def throw(self, data: bytes) -> int:
        """Send ``data``, tick once, check the counters and the state; returns the number of valid messages."""
        n = valid_messages(data)
        peer_before = self.raw_address in self.vehicle.peers
        self.raw.sendto(data, self.vehicle.address)
        self.vehicle.step()
        self.thrown += 1
        self.expected.rx_datagrams += 1
        if n:
            self.expected.rx_messages += n
            self.valid_seen += 1
        else:
            self.expected.rx_dropped += 1
            assert (self.raw_address in self.vehicle.peers) == peer_before  # garbage teaches no peer
        assert Counters.of(self.vehicle) == self.expected, data.hex()
        check_sane(self.vehicle)
        self.drain()
        return n

    def drain(self) -> None:
        while True:
            try:
                self.raw.recv(65535)
            except (BlockingIOError, InterruptedError):
                return

    def close(self) -> None:
        self.raw.close()


def check_sane(vehicle: MavlinkVehicle) -> None:
    """The simulated state is finite and every parameter is inside its declared range."""
    for name, value in vehicle.sim.state().model_dump().items():
        if isinstance(value, float):
            assert math.isfinite(value), (name, value)
    for spec in PARAMS:
        value = vehicle.params[spec.name]
        assert math.isfinite(value) and spec.minimum <= value <= spec.maximum, (spec.name, value)


def answers_normally(vehicle: MavlinkVehicle, step: bool = True) -> None:
    """A fresh client gets correct answers to PING, REQUEST_MESSAGE and PARAM_REQUEST_READ."""
    client = mavutil.mavlink_connection(
        f"udpout:{vehicle.address[0]}:{vehicle.address[1]}", source_system=254, source_component=190
    )
    try:
        mav = client.mav

        def ask(send: Any, kind: str, cond: Any = lambda msg: True) -> Any:
            """Send, and send again after half a second without the answer, as a ground station does: a vehicle
            running free streams telemetry at hundreds of times real time, and UDP drops what a busy client's
            socket cannot hold."""
            for _ in range(10):
                send()
                for _ in range(50):
                    if step:
                        vehicle.step()
                    else:
                        time.sleep(0.01)
                    while (msg := client.recv_match(blocking=False)) is not None:
                        if msg.get_type() == kind and cond(msg):
                            return msg
            return None

        pong = ask(lambda: mav.ping_send(123_456, 7, 0, 0), "PING", lambda p: p.seq == 7)
        assert pong is not None and pong.time_usec == 123_456 and pong.target_system == 254
        request = m.MAV_CMD_REQUEST_MESSAGE
        version = ask(
            lambda: mav.command_long_send(1, 1, request, 0, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0),
            "AUTOPILOT_VERSION",
        )
        assert version is not None and version.flight_sw_version >> 24 == 1
        ack = ask(
            lambda: mav.command_long_send(1, 1, request, 0, m.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0),
            "COMMAND_ACK",
            lambda a: a.command == request,
        )
        assert ack is not None and ack.result == ACCEPTED
        value = ask(
            lambda: mav.param_request_read_send(1, 1, b"MIS_TAKEOFF_ALT", -1),
            "PARAM_VALUE",
            lambda p: p.param_id == "MIS_TAKEOFF_ALT",
        )
        assert value is not None and value.param_value == vehicle.params["MIS_TAKEOFF_ALT"]
    finally:
        client.close()


def barrage(datagrams: st.SearchStrategy[bytes], flying: bool, examples: int = EXAMPLES) -> Target:
    """Throw ``examples`` datagrams at a fresh lockstep vehicle (in the air first if ``flying``); checks the end."""
    vehicle = MavlinkVehicle(Simulator(seed=11), gcs=None, api=None)
    target = Target(vehicle)
    try:
        if flying:
            vehicle.navigator.arm()
            vehicle.navigator.takeoff(20.0)
            vehicle.run_for(8.0)
            assert vehicle.sim.state().alt_agl_m > 10.0

        @settings(max_examples=examples, deadline=None, suppress_health_check=[HealthCheck.too_slow], database=None)
        @given(datagrams)
        def one(data: bytes) -> None:
            target.throw(data)

        one()
        answers_normally(vehicle)
        return target
    finally:
        target.close()
        vehicle.close()


# -- tests --------------------------------------------------------------------------------------------------------


def test_random_bytes_are_dropped_and_counted():
    target = barrage(garbage(), flying=False)
    assert target.vehicle.stats.rx_dropped == target.thrown - target.valid_seen > 0


def test_truncated_frames_are_dropped_and_counted():
    @st.composite
    def frames(draw: st.DrawFn) -> bytes:
        frame = draw(truncated_frames())
        assert valid_messages(frame) == 0
        return frame

    target = barrage(frames(), flying=True)
    assert target.valid_seen == 0 and target.vehicle.stats.rx_dropped == target.thrown > 0


def test_frames_with_a_corrupted_byte_fail_the_crc_and_are_dropped():
    @st.composite
    def frames(draw: st.DrawFn) -> bytes:
        frame = draw(corrupted_frames())
        assert valid_messages(frame) == 0
        return frame

    target = barrage(frames(), flying=True)
    assert target.valid_seen == 0 and target.vehicle.stats.rx_dropped == target.thrown > 0


@pytest.mark.parametrize("name", HANDLED)
def test_every_handled_message_with_absurd_fields_is_handled_without_a_crash(name):
    # Starting in the air; commands among the examples land, disarm, re-arm and take off again.
    target = barrage(valid_frames((name,)), flying=True, examples=PER_TYPE)
    assert target.valid_seen == target.thrown > 0 and target.vehicle.stats.rx_dropped == 0


@pytest.mark.parametrize("command", COMMANDS)
def test_every_supported_command_with_absurd_parameters_is_answered_without_a_crash(command):
    target = barrage(valid_frames(("COMMAND_LONG", "COMMAND_INT"), command), flying=True, examples=PER_TYPE)
    assert target.valid_seen == target.thrown > 0 and target.vehicle.stats.rx_dropped == 0


def test_a_vehicle_running_free_survives_mixed_bursts_and_still_answers():
    """The real set-up: the vehicle on its thread, datagrams arriving whenever they like, then a normal client."""
    vehicle = MavlinkVehicle(Simulator(seed=5), gcs=None, api=None)
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    thread = vehicle.start(speed=None)
    sent = invalid = 0
    mixed = st.one_of(garbage(), truncated_frames(), corrupted_frames(), valid_frames())

    @settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow], database=None)
    @given(st.lists(mixed, min_size=50, max_size=100))
    def burst(datagrams: list[bytes]) -> None:
        nonlocal sent, invalid
        for d in datagrams:  # one burst at a time is well inside the socket's receive buffer
            raw.sendto(d, vehicle.address)
        sent += len(datagrams)
        invalid += sum(1 for d in datagrams if valid_messages(d) == 0)
        wait_for(lambda: vehicle.stats.rx_datagrams >= sent, 10.0, 0.002, what=f"{sent} datagrams read")
        assert vehicle.stats.rx_datagrams == sent
        assert vehicle.stats.rx_dropped == invalid  # valid ones never count as dropped: no handler raised
        assert thread.is_alive()
        check_sane(vehicle)

    try:
        burst()
        answers_normally(vehicle, step=False)
        assert thread.is_alive() and vehicle.stats.rx_dropped >= invalid > 0
    finally:
        raw.close()
        vehicle.close()
