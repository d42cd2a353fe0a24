"""The agent's side of the link: an asyncio client that flies a PX4-like vehicle over MAVLink 2 on UDP.

:class:`VehicleClient` connects (waits for a HEARTBEAT, with a timeout), keeps the vehicle's telemetry current and
offers the actions a mission needs: :meth:`~VehicleClient.arm`, :meth:`~VehicleClient.takeoff`,
:meth:`~VehicleClient.goto`, :meth:`~VehicleClient.goto_local`, :meth:`~VehicleClient.orbit`,
:meth:`~VehicleClient.hover`, :meth:`~VehicleClient.hold`, :meth:`~VehicleClient.land`,
:meth:`~VehicleClient.rtl`, :meth:`~VehicleClient.deploy_payload`. Each returns a :class:`FlightResult` built from
the COMMAND_ACK *and* the state observed afterwards: ``status`` (``ok``, ``denied``, ``timeout``, ``unsupported``,
``failed``), ``reason`` (the STATUSTEXT that came with a refusal, or what went wrong), ``reached`` where a position
or state is awaited, and the telemetry at the end. Every wait has a wall-clock timeout, so no call hangs when the
vehicle stops answering.

Design: one *reader thread* owns the UDP socket. It parses each datagram with pymavlink, updates the telemetry
under a lock, sends our own HEARTBEAT once a second (ground stations do; PX4 counts them for link-loss), and
resolves waiters. A waiter is a predicate plus an asyncio future of the loop that registered it; the thread settles
the future with ``loop.call_soon_threadsafe``. So the client is not bound to one event loop: the tools executor
runs async tools on the caller's loop (``acall``) or on a background loop of its own (``call``), and the same
client serves both. The thread also means telemetry stays current while no coroutine is running.

Addresses (as pymavlink's ``mavutil``): ``"HOST:PORT"``, ``"udpout:HOST:PORT"`` or ``(host, port)`` send to the
vehicle from an ephemeral port (the vehicle answers whoever talks to it; :class:`~flight.mavlink.MavlinkVehicle`
and PX4 do); ``"udpin:HOST:PORT"`` listens there (PX4 SITL sends to 127.0.0.1:14540 for APIs) and replies to where
the vehicle's messages come from.

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``; PX4 user guide):

* MAV_RESULT: ACCEPTED 0, TEMPORARILY_REJECTED 1, DENIED 2, UNSUPPORTED 3, FAILED 4, IN_PROGRESS 5 (a final ACK
  follows), CANCELLED 6. A command without an ACK is sent again with ``confirmation`` incremented.
* Commands: NAV_RETURN_TO_LAUNCH 20, NAV_LAND 21 (param5/6 NaN: here), NAV_TAKEOFF 22 (COMMAND_LONG param7 is the
  altitude above mean sea level in PX4), DO_ORBIT 34 (param1 radius, positive clockwise; param2 velocity; param3
  yaw behaviour; param4 orbits), DO_SET_MODE 176 (param1 base mode with CUSTOM_MODE_ENABLED 1, param2 PX4 main
  mode, param3 sub mode), DO_REPOSITION 192 (param1 ground speed, -1 default; param2 flags, CHANGE_MODE 1; param4
  yaw, NaN keep; x/y degE7; z altitude in ``frame``, NaN keep), DO_GRIPPER 211 (param1 instance, param2 RELEASE 0),
  COMPONENT_ARM_DISARM 400 (param2 21196 forces), GET_HOME_POSITION 410.
* Frame MAV_FRAME_GLOBAL_RELATIVE_ALT_INT 6: altitudes above home. HOME_POSITION 242 carries home (degE7, mm AMSL).
* PX4 ``custom_mode`` = ``main << 16 | sub << 24``; AUTO 4 with sub LOITER 3 is "Hold", TAKEOFF 2, MISSION 4, RTL 5,
  LAND 6; POSCTL 3 with sub 1 is Orbit. Integer parameters are encoded bytewise in PARAM_VALUE/PARAM_SET floats.
* EXTENDED_SYS_STATE.landed_state: UNDEFINED 0, ON_GROUND 1, IN_AIR 2, TAKEOFF 3, LANDING 4.
* STATUSTEXT: 50 characters; longer texts arrive in chunks sharing a non-zero ``id``, the last one shorter.

Only PX4's mode encoding is decoded (an ArduPilot vehicle's modes would show as ``custom:<n>``).
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import math
import select
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field
from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_AUTOPILOT_INVALID,
    MAV_AUTOPILOT_PX4,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_ORBIT,
    MAV_CMD_DO_REPOSITION,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_GET_HOME_POSITION,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_PARAM_TYPE_INT32,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_IN_PROGRESS,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
    MAV_TYPE_GCS,
)

from flight.geodesy import local_offset, offset_position
from flight.px4 import (
    AutoSubMode,
    MainMode,
    decode_custom_mode,
    mavlink_text,
)

Address = tuple[str, int]
CommandStatus = Literal["ok", "denied", "timeout", "unsupported", "failed"]
LandedState = Literal["unknown", "on_ground", "in_air", "takeoff", "landing"]

MAV_RESULT_NAMES = {0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED", 4: "FAILED"}
MAV_RESULT_NAMES |= {5: "IN_PROGRESS", 6: "CANCELLED"}

COMMAND_NAMES = {
    20: "NAV_RETURN_TO_LAUNCH",
    21: "NAV_LAND",
    22: "NAV_TAKEOFF",
    34: "DO_ORBIT",
    176: "DO_SET_MODE",
    192: "DO_REPOSITION",
    211: "DO_GRIPPER",
    400: "COMPONENT_ARM_DISARM",
    410: "GET_HOME_POSITION",
}

FORCE_MAGIC = 21196
GRIPPER_ACTION_RELEASE = 0
STATUSTEXT_LEN = 50
UINT16_MAX = 0xFFFF

PX4_MODES: dict[tuple[int, int], str] = {
    (1, 0): "manual",
    (2, 0): "altitude",
    (3, 0): "position",
    (3, 1): "orbit",
    (4, 1): "ready",
    (4, 2): "takeoff",
    (4, 3): "hold",
    (4, 4): "mission",
    (4, 5): "rtl",
    (4, 6): "land",
    (4, 8): "follow_target",
    (4, 9): "precland",
    (5, 0): "acro",
    (6, 0): "offboard",
    (7, 0): "stabilized",
}
LANDED_STATES: dict[int, LandedState] = {1: "on_ground", 2: "in_air", 3: "takeoff", 4: "landing"}

FLYING_MODES = frozenset({"hold", "takeoff", "position", "orbit"})
"""Modes in which a go-to, take-off, orbit or hover is still being flown; a switch to any other (RTL, Land: a
failsafe, or another client) interrupts it."""

LINK_TIMEOUT_S = 3.0
"""No message from the vehicle for this long: ``Telemetry.connected`` is false."""
ACK_TIMEOUT_S = 1.5
ACK_ATTEMPTS = 3
DENIAL_TEXT_WAIT_S = 0.3
"""After a refusal, how long to wait for the STATUSTEXT that says why if it has not come before the ACK."""


def parse_address(address: str | Address) -> tuple[Address, bool]:
    """``(host, port)`` and whether to listen there (``udpin:``) rather than send to it."""
    if isinstance(address, tuple):
        return (str(address[0]), int(address[1])), False
    text = address.strip()
    listen = False
    for prefix, is_in in (("udpin:", True), ("udpout:", False), ("udp:", False)):
        if text.startswith(prefix):
            text, listen = text[len(prefix) :], is_in
            break
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise ValueError(f"bad MAVLink address {address!r}: use HOST:PORT, udpin:HOST:PORT or udpout:HOST:PORT")
    return (host or "0.0.0.0", int(port)), listen


class VehicleConnectionError(ConnectionError):
    """No heartbeat from a vehicle within the connect timeout (or the socket could not be opened)."""


class _Heard(BaseModel):
    """The vehicle's state as its messages report it: kept by the reader thread, snapshot in :class:`Telemetry`."""

    time_boot_s: float | None = Field(default=None, description="the vehicle's clock (simulated time in a sim)")
    lat_deg: float | None = None
    lon_deg: float | None = None
    alt_msl_m: float | None = None
    alt_m: float | None = Field(default=None, description="altitude above home")
    north_m: float | None = Field(default=None, description="LOCAL_POSITION_NED, from the local origin")
    east_m: float | None = None
    down_m: float | None = None
    vn_mps: float | None = None
    ve_mps: float | None = None
    vd_mps: float | None = None
    heading_deg: float | None = None
    battery_pct: float | None = None
    battery_voltage_v: float | None = None
    armed: bool = False
    mode: str = "unknown"
    landed_state: LandedState = "unknown"


class Telemetry(_Heard):
    """What the client last heard from the vehicle. ``None`` where nothing has been heard yet."""

    model_config = ConfigDict(frozen=True)

    connected: bool = Field(description="a message arrived within the last few seconds")
    home_lat_deg: float | None = None
    home_lon_deg: float | None = None
    home_alt_msl_m: float | None = None
    last_text: str | None = Field(default=None, description="the last STATUSTEXT")

    @property
    def groundspeed_mps(self) -> float | None:
        if self.vn_mps is None or self.ve_mps is None:
            return None
        return math.hypot(self.vn_mps, self.ve_mps)


class FlightResult(BaseModel):
    """The outcome of one action: the vehicle's answer and what was then observed."""

    model_config = ConfigDict(frozen=True)

    action: str
    status: CommandStatus
    reason: str | None = Field(default=None, description="why it was refused or did not complete; notes otherwise")
    reached: bool | None = Field(default=None, description="for actions that await a position or state")
    ack: int | None = Field(default=None, description="MAV_RESULT of the last COMMAND_ACK, None if none came")
    elapsed_s: float = Field(ge=0, description="wall time")
    state: Telemetry

    @property
    def ok(self) -> bool:
        return self.status == "ok"


class _State(_Heard):
    """The mutable telemetry the reader thread keeps (under the client's lock)."""

    model_config = ConfigDict(arbitrary_types_allowed=True)

    last_rx: float = -math.inf
    home: tuple[float, float, float] | None = None
    texts: deque[tuple[int, str]] = Field(default_factory=lambda: deque(maxlen=50))
    """(serial number, text) of the last STATUSTEXTs."""
    text_count: int = 0


@dataclass(slots=True)
class _Ack:
    result: int | None
    reason: str | None

    @property
    def accepted(self) -> bool:
        return bool(self.result == MAV_RESULT_ACCEPTED)


@dataclass(eq=False, slots=True)
class _Waiter:
    loop: asyncio.AbstractEventLoop
    future: asyncio.Future[Any]
    match: Callable[[Any], Any]
    """Called with each message from the vehicle (and None for the state as it is); not None settles the wait."""


@dataclass(eq=False, slots=True)
class _Op:
    """A motion command under way; a newer one supersedes it."""

    action: str
    started: float
    start_mode: str
    text_mark: int
    superseded_by: str | None = None
    left_start_mode: bool = False


def _resolve(future: asyncio.Future[Any], value: Any) -> None:
    if not future.done():
        future.set_result(value)


class TelemetrySubscription:
    """An async iterator of :class:`Telemetry` snapshots, one per change (coalesced: a slow reader gets the latest,
    never a backlog). Use it on the loop that created it; close it (or leave its ``async with``) when done."""

    def __init__(self, client: VehicleClient) -> None:
        self._client = client
        self._loop = asyncio.get_running_loop()
        self._event = asyncio.Event()
        self._pending = False
        self.closed = False

    def _notify(self) -> None:  # the reader thread, under the client's lock
        if not self._pending and not self.closed:
            self._pending = True
            with contextlib.suppress(RuntimeError):  # the loop has closed
                self._loop.call_soon_threadsafe(self._event.set)

    def __aiter__(self) -> TelemetrySubscription:
        return self

    async def __anext__(self) -> Telemetry:
        if self.closed:
            raise StopAsyncIteration
        await self._event.wait()
        self._event.clear()
        self._pending = False
        if self.closed:
            raise StopAsyncIteration
        return self._client.telemetry

    def close(self) -> None:
        self.closed = True
        self._client._unsubscribe(self)
        self._event.set()

    async def __aenter__(self) -> TelemetrySubscription:
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()


class VehicleClient:
    """A MAVLink client for one vehicle. Make it with :meth:`connect`; close it (or ``async with``) when done."""

    def __init__(
        self,
        address: str | Address,
        *,
        source_system: int = 255,
        source_component: int = 190,
        target_system: int | None = None,
        heartbeat_hz: float = 1.0,
        ack_timeout_s: float = ACK_TIMEOUT_S,
        ack_attempts: int = ACK_ATTEMPTS,
    ) -> None:
        if not (1 <= source_system <= 255 and 0 <= source_component <= 255):
            raise ValueError("source system is 1..255, component 0..255")
        if not heartbeat_hz > 0:
            raise ValueError("heartbeat_hz must be positive")
        where, listen = parse_address(address)
        self.source_system = source_system
        self.source_component = source_component
        self.target_system = target_system
        """The vehicle's system id (learnt from its first heartbeat when not given)."""
        self.target_component = 1
        self._heartbeat_period_s = 1.0 / heartbeat_hz
        self.ack_timeout_s = ack_timeout_s
        """How long to wait for a COMMAND_ACK before sending the command again."""
        self.ack_attempts = max(1, ack_attempts)
        self._mav = mavlink2.MAVLink(None, srcSystem=source_system, srcComponent=source_component)
        self._lock = threading.RLock()
        self._state = _State()
        self._waiters: list[_Waiter] = []
        self._subscriptions: list[TelemetrySubscription] = []
        self._chunks: dict[tuple[int, int, int], list[str]] = {}
        self._param_types: dict[str, int] = {}
        self._op: _Op | None = None
        self._closed = threading.Event()
        self.rx_messages = 0
        self.rx_dropped = 0
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            loopback = where[0] in ("127.0.0.1", "localhost")
            self._sock.bind(where if listen else ("127.0.0.1" if loopback else "", 0))
            self._sock.setblocking(False)
        except OSError as exc:
            self._sock.close()
            raise VehicleConnectionError(f"cannot open a UDP socket for {address!r}: {exc}") from exc
        self._remote: Address | None = None if listen else where
        self._thread = threading.Thread(target=self._read_loop, name="mavlink-client", daemon=True)
        self._thread.start()

    # -- lifecycle --------------------------------------------------------------------------------------------

    @classmethod
    async def connect(
        cls,
        address: str | Address,
        timeout_s: float = 10.0,
        *,
        source_system: int = 255,
        source_component: int = 190,
        target_system: int | None = None,
        heartbeat_hz: float = 1.0,
        ack_timeout_s: float = ACK_TIMEOUT_S,
        ack_attempts: int = ACK_ATTEMPTS,
    ) -> VehicleClient:
        """Open the link and wait for the vehicle's HEARTBEAT; :class:`VehicleConnectionError` after ``timeout_s``."""
        client = cls(
            address,
            source_system=source_system,
            source_component=source_component,
            target_system=target_system,
            heartbeat_hz=heartbeat_hz,
            ack_timeout_s=ack_timeout_s,
            ack_attempts=ack_attempts,
        )
        try:
            beat = await client._wait(lambda m: m if m is not None and m.get_type() == "HEARTBEAT" else None, timeout_s)
        except BaseException:
            client.close()
            raise
        if beat is None:
            client.close()
            raise VehicleConnectionError(f"no heartbeat from a vehicle at {address!r} in {timeout_s:g} s")
        if client.home is None:  # PX4 streams HOME_POSITION slowly or only on request
            client._send_command_long(MAV_CMD_GET_HOME_POSITION, (0.0,) * 7)
        return client

    @property
    def address(self) -> Address:
        """Our bound (host, port)."""
        host, port = self._sock.getsockname()[:2]
        return str(host), int(port)

    @property
    def remote(self) -> Address | None:
        """Where the vehicle is (None until heard from, when listening)."""
        return self._remote

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    def close(self) -> None:
        """Stop the reader thread and close the socket (idempotent). Pending waits end as timeouts."""
        if self._closed.is_set():
            return
        self._closed.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        with self._lock:
            for sub in list(self._subscriptions):
                sub.closed = True
                sub._notify()
            self._subscriptions.clear()
        self._sock.close()

    async def __aenter__(self) -> VehicleClient:
        return self

    async def __aexit__(self, *exc: object) -> None:
        self.close()

    # -- telemetry --------------------------------------------------------------------------------------------

    @property
    def telemetry(self) -> Telemetry:
        """A snapshot of the latest telemetry."""
        with self._lock:
            s = self._state
            home = s.home
            return Telemetry(
                **{name: getattr(s, name) for name in _Heard.model_fields},
                connected=time.monotonic() - s.last_rx < LINK_TIMEOUT_S and not self.closed,
                home_lat_deg=home[0] if home else None,
                home_lon_deg=home[1] if home else None,
                home_alt_msl_m=home[2] if home else None,
                last_text=s.texts[-1][1] if s.texts else None,
            )

    @property
    def home(self) -> tuple[float, float, float] | None:
        """(lat, lon, alt above mean sea level) of home, once HOME_POSITION has arrived."""
        with self._lock:
            return self._state.home

    def subscribe(self) -> TelemetrySubscription:
        """Telemetry updates as an async iterator (call it on the loop that reads them)."""
        sub = TelemetrySubscription(self)
        with self._lock:
            self._subscriptions.append(sub)
        return sub

    def _unsubscribe(self, sub: TelemetrySubscription) -> None:
        with self._lock, contextlib.suppress(ValueError):
            self._subscriptions.remove(sub)

    def texts_since(self, mark: int) -> list[str]:
        """STATUSTEXTs received after ``mark`` (a value of :attr:`text_mark`)."""
        with self._lock:
            return [text for n, text in self._state.texts if n > mark]

    @property
    def text_mark(self) -> int:
        with self._lock:
            return self._state.text_count

    # -- the reader thread ------------------------------------------------------------------------------------

    def _read_loop(self) -> None:
        next_beat = 0.0
        while not self._closed.is_set():
            now = time.monotonic()
            if now >= next_beat:
                next_beat = now + self._heartbeat_period_s
                self._send(self._mav.heartbeat_encode(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0))
            try:
                readable, _, _ = select.select([self._sock], [], [], min(0.1, max(0.0, next_beat - now)))
            except (OSError, ValueError):  # closed under us
                return
            if not readable:
                continue
            for _ in range(1000):
                try:
                    data, sender = self._sock.recvfrom(65535)
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    if self._closed.is_set():
                        return
                    break
                self._datagram(data, (str(sender[0]), int(sender[1])))

    def _datagram(self, data: bytes, sender: Address) -> None:
        parser = mavlink2.MAVLink(None)
        parser.robust_parsing = True
        try:
            msgs = [m for m in parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]
        except Exception:
            msgs = []
        if not msgs:
            self.rx_dropped += 1
            return
        with self._lock:
            for msg in msgs:
                if not self._from_vehicle(msg, sender):
                    continue
                self.rx_messages += 1
                try:
                    changed = self._update(msg)
                except Exception:  # a malformed field must not stop the reader
                    self.rx_dropped += 1
                    continue
                self._settle_waiters(msg)
                if changed:
                    for sub in self._subscriptions:
                        sub._notify()

    def _from_vehicle(self, msg: Any, sender: Address) -> bool:
        src = msg.get_srcSystem()
        if self.target_system is None:
            if msg.get_type() != "HEARTBEAT" or msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
                return False
            self.target_system, self.target_component = src, msg.get_srcComponent()
        if src != self.target_system:
            return False
        if self._remote is None:
            self._remote = sender
        return True

    def _update(self, msg: Any) -> bool:
        """Fold ``msg`` into the state; True if the telemetry changed."""
        s = self._state
        s.last_rx = time.monotonic()
        kind = msg.get_type()
        own = msg.get_srcComponent() == self.target_component
        if kind == "HEARTBEAT" and own:
            s.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
            if msg.autopilot == MAV_AUTOPILOT_PX4 and msg.base_mode & MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                main, sub = decode_custom_mode(msg.custom_mode)
                s.mode = PX4_MODES.get((main, sub), f"px4:{main}/{sub}")
            else:
                s.mode = f"custom:{msg.custom_mode}"
        elif kind == "GLOBAL_POSITION_INT":
            s.time_boot_s = msg.time_boot_ms / 1000.0
            s.lat_deg, s.lon_deg = msg.lat / 1e7, msg.lon / 1e7
            s.alt_msl_m, s.alt_m = msg.alt / 1000.0, msg.relative_alt / 1000.0
            s.vn_mps, s.ve_mps, s.vd_mps = msg.vx / 100.0, msg.vy / 100.0, msg.vz / 100.0
            s.heading_deg = None if msg.hdg == UINT16_MAX else msg.hdg / 100.0
        elif kind == "LOCAL_POSITION_NED":
            s.north_m, s.east_m, s.down_m = float(msg.x), float(msg.y), float(msg.z)
        elif kind == "SYS_STATUS":
            s.battery_pct = None if msg.battery_remaining < 0 else float(msg.battery_remaining)
            s.battery_voltage_v = None if msg.voltage_battery == UINT16_MAX else msg.voltage_battery / 1000.0
        elif kind == "EXTENDED_SYS_STATE":
            s.landed_state = LANDED_STATES.get(msg.landed_state, "unknown")
        elif kind == "HOME_POSITION":
            s.home = (msg.latitude / 1e7, msg.longitude / 1e7, msg.altitude / 1000.0)
        elif kind == "STATUSTEXT":
            self._statustext(msg)
        elif kind == "PARAM_VALUE":
            self._param_types[mavlink_text(msg.param_id)] = int(msg.param_type)
            return False
        else:
            return False
        return True

    def _statustext(self, msg: Any) -> None:
        text = mavlink_text(msg.text)
        chunk_id = getattr(msg, "id", 0)
        if chunk_id:
            key = (msg.get_srcSystem(), msg.get_srcComponent(), chunk_id)
            parts = self._chunks.setdefault(key, [])
            parts.append(text)
            if len(text.encode()) >= STATUSTEXT_LEN:
                if len(self._chunks) > 16:  # never-finished texts must not pile up
                    del self._chunks[next(iter(self._chunks))]
                return
            text = "".join(self._chunks.pop(key))
        self._state.text_count += 1
        self._state.texts.append((self._state.text_count, text))

    def _settle_waiters(self, msg: Any) -> None:
        for waiter in list(self._waiters):
            try:
                value = waiter.match(msg)
            except Exception as exc:  # a predicate's bug ends its own wait, not the reader
                value = exc
            if value is None:
                continue
            self._waiters.remove(waiter)
            with contextlib.suppress(RuntimeError):  # its loop has closed: nobody waits any more
                waiter.loop.call_soon_threadsafe(_resolve, waiter.future, value)

    # -- sending ----------------------------------------------------------------------------------------------

    def _send(self, msg: Any) -> None:
        remote = self._remote
        if remote is None or self._closed.is_set():
            return
        with self._lock:
            buf = msg.pack(self._mav)
            self._mav.seq = (self._mav.seq + 1) % 256
        with contextlib.suppress(OSError):
            self._sock.sendto(buf, remote)

    def _target(self) -> tuple[int, int]:
        return self.target_system or 1, self.target_component

    def _send_command_long(self, command: int, params: tuple[float, ...], confirmation: int = 0) -> None:
        ts, tc = self._target()
        self._send(self._mav.command_long_encode(ts, tc, command, confirmation, *params))

    def _send_command_int(
        self, command: int, frame: int, params: tuple[float, float, float, float], x: int, y: int, z: float
    ) -> None:
        ts, tc = self._target()
        self._send(self._mav.command_int_encode(ts, tc, frame, command, 0, 0, *params, x, y, z))

    # -- waiting ----------------------------------------------------------------------------------------------

    async def _wait(self, match: Callable[[Any], Any], timeout_s: float, send: Callable[[], None] | None = None) -> Any:
        """The first non-None ``match(msg)`` (``match(None)`` is tried at once on the current state), or None
        after ``timeout_s``. An exception the predicate raised is returned, not raised. ``send`` sends the request
        whose answer is awaited: only once the waiter is in place, or a quick answer would slip past it."""
        loop = asyncio.get_running_loop()
        future: asyncio.Future[Any] = loop.create_future()
        waiter = _Waiter(loop, future, match)
        with self._lock:
            now = match(None)
            if now is not None:
                return now
            if self.closed:
                return None
            self._waiters.append(waiter)
        try:
            if send is not None:
                send()
            async with asyncio.timeout(max(0.0, timeout_s)):
                return await future
        except TimeoutError:
            return None
        finally:
            with self._lock, contextlib.suppress(ValueError):
                self._waiters.remove(waiter)

    async def command(
        self,
        command: int,
        params: tuple[float, ...] = (),
        *,
        frame: int | None = None,
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        timeout_s: float | None = None,
        attempts: int | None = None,
    ) -> tuple[int | None, str | None]:
        """Send a COMMAND_LONG (or a COMMAND_INT when ``frame`` is given) and wait for its final COMMAND_ACK,
        resending when none comes (``timeout_s``/``attempts`` default to the client's). Returns (MAV_RESULT or
        None on timeout, the reason for a refusal)."""
        ack = await self._command(command, params, frame=frame, x=x, y=y, z=z, timeout_s=timeout_s, attempts=attempts)
        return ack.result, ack.reason

    async def _command(
        self,
        command: int,
        params: tuple[float, ...],
        *,
        frame: int | None = None,
        x: int = 0,
        y: int = 0,
        z: float = 0.0,
        timeout_s: float | None = None,
        attempts: int | None = None,
    ) -> _Ack:
        timeout_s = self.ack_timeout_s if timeout_s is None else timeout_s
        attempts = self.ack_attempts if attempts is None else max(1, attempts)
        full = (*params, *([0.0] * (7 - len(params))))[:7] if frame is None else (*params, 0.0, 0.0, 0.0, 0.0)[:4]
        mark = self.text_mark

        def is_ack(msg: Any) -> Any:
            if msg is None or msg.get_type() != "COMMAND_ACK" or msg.command != command:
                return None
            if msg.target_system not in (0, self.source_system):
                return None
            return msg if msg.result != MAV_RESULT_IN_PROGRESS else None

        ack = None

        def send(confirmation: int) -> None:
            if frame is None:
                self._send_command_long(command, full, confirmation=confirmation)
            else:
                p = (float(full[0]), float(full[1]), float(full[2]), float(full[3]))
                self._send_command_int(command, frame, p, x, y, z)

        for attempt in range(attempts):
            ack = await self._wait(is_ack, timeout_s, send=functools.partial(send, min(attempt, 255)))
            if ack is not None:
                break
        name = COMMAND_NAMES.get(command, str(command))
        if ack is None:
            return _Ack(None, f"no COMMAND_ACK for {name} after {attempts} attempt(s) of {timeout_s:g} s")
        result = int(ack.result)
        if result == MAV_RESULT_ACCEPTED:
            return _Ack(result, None)
        texts = self.texts_since(mark)
        if not texts and result in (MAV_RESULT_DENIED, MAV_RESULT_TEMPORARILY_REJECTED, MAV_RESULT_FAILED):
            await self._wait(
                lambda m: m if m is not None and m.get_type() == "STATUSTEXT" else None, DENIAL_TEXT_WAIT_S
            )
            texts = self.texts_since(mark)
        label = MAV_RESULT_NAMES.get(result, str(result))
        if result == MAV_RESULT_UNSUPPORTED:
            reason = f"the vehicle does not support {name} (MAV_RESULT_UNSUPPORTED)"
        else:
            reason = "; ".join(texts) if texts else f"{name}: MAV_RESULT_{label}"
        return _Ack(result, reason)

    # -- parameters -------------------------------------------------------------------------------------------

    async def get_param(self, name: str, timeout_s: float = 5.0) -> float | None:
        """A parameter's value (integers decoded from PX4's bytewise encoding), or None if none came."""
        ts, tc = self._target()
        for _ in range(2):
            request = self._mav.param_request_read_encode(ts, tc, name.encode(), -1)
            msg = await self._wait(self._param_match(name), timeout_s / 2, send=functools.partial(self._send, request))
            if msg is not None:
                return self._param_decode(msg)
        return None

    async def set_param(self, name: str, value: float, timeout_s: float = 5.0) -> float | None:
        """Set a parameter; returns the value the vehicle echoes (it may refuse and echo the old one), or None
        without an answer. The type is the vehicle's (read first when not yet known)."""
        if name not in self._param_types and await self.get_param(name, timeout_s) is None:
            return None
        ptype = self._param_types[name]
        wire = struct.unpack("<f", struct.pack("<i", round(value)))[0] if ptype == MAV_PARAM_TYPE_INT32 else value
        ts, tc = self._target()
        request = self._mav.param_set_encode(ts, tc, name.encode(), float(wire), ptype)
        msg = await self._wait(self._param_match(name), timeout_s, send=functools.partial(self._send, request))
        return None if msg is None else self._param_decode(msg)

    @staticmethod
    def _param_match(name: str) -> Callable[[Any], Any]:
        return lambda m: (
            m if m is not None and m.get_type() == "PARAM_VALUE" and mavlink_text(m.param_id) == name else None
        )

    @staticmethod
    def _param_decode(msg: Any) -> float:
        if msg.param_type == MAV_PARAM_TYPE_INT32:
            return float(struct.unpack("<i", struct.pack("<f", msg.param_value))[0])
        return float(msg.param_value)

    # -- actions ----------------------------------------------------------------------------------------------

    def _begin(self, action: str) -> _Op:
        """Start a motion command: the one under way (if any) is superseded by it."""
        with self._lock:
            if self._op is not None:
                self._op.superseded_by = action
            self._op = _Op(action, time.monotonic(), self._state.mode, self._state.text_count)
            return self._op

    def _end(self, op: _Op) -> None:
        with self._lock:
            if self._op is op:
                self._op = None

    def _result(
        self,
        op: _Op,
        status: CommandStatus,
        *,
        reason: str | None = None,
        reached: bool | None = None,
        ack: int | None = None,
    ) -> FlightResult:
        self._end(op)
        return FlightResult(
            action=op.action,
            status=status,
            reason=reason,
            reached=reached,
            ack=ack,
            elapsed_s=time.monotonic() - op.started,
            state=self.telemetry,
        )

    def _refused(self, op: _Op, ack: _Ack) -> FlightResult:
        status: CommandStatus
        if ack.result is None:
            status = "timeout"
        elif ack.result in (MAV_RESULT_DENIED, MAV_RESULT_TEMPORARILY_REJECTED):
            status = "denied"
        elif ack.result == MAV_RESULT_UNSUPPORTED:
            status = "unsupported"
        else:
            status = "failed"
        return self._result(op, status, reason=ack.reason, ack=ack.result)

    async def _fly_wait(
        self,
        op: _Op,
        done: Callable[[_State], bool],
        timeout_s: float,
        *,
        flying: bool = True,
    ) -> tuple[CommandStatus, str | None, bool]:
        """Wait until ``done(state)``. (status, reason, reached): ``failed`` when superseded by a newer command or,
        for ``flying`` actions, when the vehicle disarms or switches to a mode that is not flying it."""

        def check(_msg: Any) -> Any:
            s = self._state
            if done(s):
                return "reached"
            if op.superseded_by is not None:
                return f"superseded by {op.superseded_by}"
            if flying:
                if s.mode != op.start_mode:
                    op.left_start_mode = True
                if op.left_start_mode and s.mode not in FLYING_MODES:
                    return f"interrupted: the vehicle switched to {s.mode}"
                if not s.armed and op.left_start_mode:
                    return "interrupted: the vehicle disarmed"
            return None

        outcome = await self._wait(check, timeout_s)
        if outcome == "reached":
            return "ok", None, True
        texts = self.texts_since(op.text_mark)
        if outcome is None:
            why = f"not reached in {timeout_s:.0f} s"
            if not self.telemetry.connected:
                why += " (no telemetry from the vehicle)"
            return "timeout", why, False
        if isinstance(outcome, Exception):
            return "failed", f"internal error: {outcome}", False
        reason = str(outcome) + (f" ({texts[-1]})" if texts else "")
        return "failed", reason, False

    async def arm(self, *, force: bool = False, timeout_s: float = 10.0) -> FlightResult:
        """Arm (pre-arm checks apply unless ``force``) and wait until the vehicle reports armed."""
        op = self._begin("arm")
        ack = await self._command(MAV_CMD_COMPONENT_ARM_DISARM, (1.0, float(FORCE_MAGIC) if force else 0.0))
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: s.armed, timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def disarm(self, *, force: bool = False, timeout_s: float = 10.0) -> FlightResult:
        """Disarm (refused in the air unless ``force``, which drops the aircraft)."""
        op = self._begin("disarm")
        ack = await self._command(MAV_CMD_COMPONENT_ARM_DISARM, (0.0, float(FORCE_MAGIC) if force else 0.0))
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: not s.armed, timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def _home_alt(self, timeout_s: float = 3.0) -> float | None:
        """Home's altitude above mean sea level: HOME_POSITION, else GLOBAL_POSITION_INT's alt − relative_alt."""

        def known(_msg: Any) -> Any:
            s = self._state
            if s.home is not None:
                return s.home[2]
            if s.alt_msl_m is not None and s.alt_m is not None:
                return s.alt_msl_m - s.alt_m
            return None

        return await self._wait(known, timeout_s)  # type: ignore[no-any-return]

    async def _home_position(self, timeout_s: float = 3.0) -> tuple[float, float, float] | None:
        if self.home is None:
            self._send_command_long(MAV_CMD_GET_HOME_POSITION, (0.0,) * 7)
        return await self._wait(lambda _m: self._state.home, timeout_s)  # type: ignore[no-any-return]

    async def takeoff(self, alt_m: float, *, timeout_s: float | None = None, tolerance_m: float = 0.6) -> FlightResult:
        """Take off to ``alt_m`` above home (armed first: see :meth:`arm`) and wait until there."""
        op = self._begin("takeoff")
        if not (math.isfinite(alt_m) and alt_m > 0):
            return self._result(op, "failed", reason=f"take-off altitude must be positive, got {alt_m}")
        home_alt = await self._home_alt()
        if home_alt is None:
            return self._result(op, "timeout", reason="no HOME_POSITION or GLOBAL_POSITION_INT to know home's altitude")
        nan = math.nan
        ack = await self._command(MAV_CMD_NAV_TAKEOFF, (0.0, 0.0, 0.0, nan, nan, nan, home_alt + alt_m))
        if not ack.accepted:
            return self._refused(op, ack)
        wait = timeout_s if timeout_s is not None else 30.0 + alt_m / 1.0

        def there(s: _State) -> bool:
            return s.alt_m is not None and abs(s.alt_m - alt_m) < tolerance_m

        status, reason, reached = await self._fly_wait(op, there, wait)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    def _distance_to(self, s: _State, lat: float, lon: float) -> float | None:
        if s.lat_deg is None or s.lon_deg is None:
            return None
        north, east = local_offset(lat, lon, s.lat_deg, s.lon_deg)
        return math.hypot(north, east)

    async def goto(
        self,
        lat: float,
        lon: float,
        alt_m: float | None = None,
        *,
        speed_mps: float | None = None,
        yaw_deg: float | None = None,
        timeout_s: float | None = None,
        acceptance_m: float = 1.5,
        alt_tolerance_m: float = 1.0,
        action: str = "goto",
    ) -> FlightResult:
        """Fly to ``lat, lon`` at ``alt_m`` above home (None: keep the altitude) with DO_REPOSITION, and wait until
        within ``acceptance_m`` horizontally and ``alt_tolerance_m`` vertically."""
        op = self._begin(action)
        if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return self._result(op, "failed", reason=f"position out of range: {lat}, {lon}")
        if alt_m is not None and not math.isfinite(alt_m):
            return self._result(op, "failed", reason="altitude is not a number")
        params = (
            float(speed_mps) if speed_mps is not None and speed_mps > 0 else -1.0,
            float(MAV_DO_REPOSITION_FLAGS_CHANGE_MODE),
            0.0,
            math.nan if yaw_deg is None else float(yaw_deg),
        )
        z = math.nan if alt_m is None else float(alt_m)
        ack = await self._command(
            MAV_CMD_DO_REPOSITION,
            params,
            frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x=round(lat * 1e7),
            y=round(lon * 1e7),
            z=z,
        )
        if not ack.accepted:
            return self._refused(op, ack)
        if timeout_s is None:
            with self._lock:
                s = self._state
                dist = self._distance_to(s, lat, lon) or 0.0
                climb = abs(alt_m - s.alt_m) if alt_m is not None and s.alt_m is not None else 0.0
            timeout_s = 30.0 + dist / 2.0 + climb

        def there(s: _State) -> bool:
            dist = self._distance_to(s, lat, lon)
            if dist is None or dist > acceptance_m:
                return False
            return alt_m is None or (s.alt_m is not None and abs(s.alt_m - alt_m) <= alt_tolerance_m)

        status, reason, reached = await self._fly_wait(op, there, timeout_s)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def goto_local(
        self, north_m: float, east_m: float, alt_m: float | None = None, **kwargs: Any
    ) -> FlightResult:
        """:meth:`goto` a point ``north_m``/``east_m`` from home (takes :meth:`goto`'s keyword options)."""
        home = await self._home_position()
        if home is None:
            op = self._begin(kwargs.get("action", "goto"))
            return self._result(op, "timeout", reason="home position unknown (no HOME_POSITION)")
        lat, lon = offset_position(home[0], home[1], north_m, east_m)
        return await self.goto(lat, lon, alt_m, **kwargs)

    async def hold(self, *, timeout_s: float = 5.0) -> FlightResult:
        """Switch to Hold (PX4 AUTO.LOITER): stop and hover where the vehicle is."""
        op = self._begin("hold")
        ack = await self._command(
            MAV_CMD_DO_SET_MODE,
            (float(MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(MainMode.AUTO), float(AutoSubMode.LOITER)),
        )
        if not ack.accepted:
            return self._refused(op, ack)
        status, reason, reached = await self._fly_wait(op, lambda s: s.mode == "hold", timeout_s, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def hover(self, duration_s: float, *, timeout_s: float | None = None) -> FlightResult:
        """Hold for ``duration_s`` of the *vehicle's* clock (GLOBAL_POSITION_INT.time_boot_ms: simulated time in a
        simulator, so a faster-than-real-time sim hovers in less wall time)."""
        held = await self.hold()
        if not held.ok:
            return held.model_copy(update={"action": "hover"})
        op = self._begin("hover")
        start = self.telemetry.time_boot_s
        if start is None:
            return self._result(op, "failed", reason="no GLOBAL_POSITION_INT: the vehicle's clock is unknown")
        wait = timeout_s if timeout_s is not None else 2.0 * duration_s + 30.0

        def elapsed(s: _State) -> bool:
            return s.time_boot_s is not None and s.time_boot_s - start >= duration_s

        status, reason, _ = await self._fly_wait(op, elapsed, wait)
        return self._result(op, status, reason=reason, ack=held.ack)

    def _landed(self, s: _State) -> bool:
        return not s.armed or s.landed_state == "on_ground"

    async def land(self, *, timeout_s: float | None = None) -> FlightResult:
        """Land where the vehicle is and wait until it is on the ground (PX4 disarms on touchdown)."""
        op = self._begin("land")
        nan = math.nan
        ack = await self._command(MAV_CMD_NAV_LAND, (0.0, 0.0, 0.0, nan, nan, nan, nan))
        if not ack.accepted:
            return self._refused(op, ack)
        with self._lock:
            alt = self._state.alt_m or 0.0
        wait = timeout_s if timeout_s is not None else 30.0 + abs(alt) / 0.5
        status, reason, reached = await self._fly_wait(op, self._landed, wait, flying=False)
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def rtl(self, *, timeout_s: float | None = None, home_acceptance_m: float = 5.0) -> FlightResult:
        """Return to launch and land there; ``reached`` is landed within ``home_acceptance_m`` of home."""
        op = self._begin("rtl")
        ack = await self._command(MAV_CMD_NAV_RETURN_TO_LAUNCH, ())
        if not ack.accepted:
            return self._refused(op, ack)
        home = self.home
        with self._lock:
            s = self._state
            dist = (self._distance_to(s, home[0], home[1]) if home else None) or 0.0
            alt = s.alt_m or 0.0
        wait = timeout_s if timeout_s is not None else 60.0 + dist / 2.0 + 2.0 * alt
        status, reason, landed = await self._fly_wait(op, self._landed, wait, flying=False)
        reached = landed
        if landed and home is not None:
            with self._lock:
                off = self._distance_to(self._state, home[0], home[1])
            if off is not None and off > home_acceptance_m:
                reached, reason = False, f"landed {off:.1f} m from home"
        return self._result(op, status, reason=reason, reached=reached, ack=ack.result)

    async def deploy_payload(self, *, instance: int = 1) -> FlightResult:
        """Release the payload (DO_GRIPPER RELEASE). There is no telemetry of the payload: the ACK is the answer."""
        op = self._begin("deploy_payload")
        ack = await self._command(MAV_CMD_DO_GRIPPER, (float(instance), float(GRIPPER_ACTION_RELEASE)))
        if not ack.accepted:
            return self._refused(op, ack)
        return self._result(op, "ok", ack=ack.result)

    async def orbit(
        self,
        lat: float,
        lon: float,
        radius_m: float,
        *,
        turns: float = 1.0,
        alt_m: float | None = None,
        speed_mps: float | None = None,
        clockwise: bool = True,
        timeout_s: float | None = None,
    ) -> FlightResult:
        """Circle ``lat, lon`` at ``radius_m`` for ``turns``, then hold. Tries DO_ORBIT and counts the turns from
        the position; a vehicle that answers it UNSUPPORTED (the simulated one does) is flown around the circle
        as DO_REPOSITION waypoints instead, which ``reason`` says."""
        if not (radius_m > 0 and turns > 0 and math.isfinite(radius_m) and math.isfinite(turns)):
            op = self._begin("orbit")
            return self._result(op, "failed", reason="radius_m and turns must be positive")
        circumference = 2.0 * math.pi * radius_m
        if timeout_s is None:
            with self._lock:
                dist = self._distance_to(self._state, lat, lon) or 0.0
            timeout_s = 60.0 + (dist + turns * circumference) / 1.5
        deadline = time.monotonic() + timeout_s
        op = self._begin("orbit")
        direction = 1.0 if clockwise else -1.0
        ack = await self._command(
            MAV_CMD_DO_ORBIT,
            (direction * radius_m, math.nan if speed_mps is None else speed_mps, 0.0, turns),
            frame=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            x=round(lat * 1e7),
            y=round(lon * 1e7),
            z=math.nan if alt_m is None else alt_m,
        )  # resent like every command when no ACK comes: a second identical orbit changes nothing
        if ack.result == MAV_RESULT_UNSUPPORTED:
            self._end(op)
            return await self._orbit_waypoints(lat, lon, radius_m, turns, alt_m, speed_mps, direction, deadline)
        if not ack.accepted:
            return self._refused(op, ack)
        # DO_ORBIT accepted: count the angle swept around the centre, then hold.
        swept = [0.0, math.nan]

        def turned(s: _State) -> bool:
            if s.lat_deg is None or s.lon_deg is None:
                return False
            north, east = local_offset(lat, lon, s.lat_deg, s.lon_deg)
            if math.hypot(north, east) < 0.5 * radius_m:
                return False
            angle = math.atan2(east, north)
            if not math.isnan(swept[1]):
                swept[0] += math.remainder(angle - swept[1], 2.0 * math.pi) * direction
            swept[1] = angle
            return swept[0] >= turns * 2.0 * math.pi

        status, reason, reached = await self._fly_wait(op, turned, max(0.0, deadline - time.monotonic()))
        if status != "ok":
            return self._result(op, status, reason=reason, reached=reached, ack=ack.result)
        self._end(op)
        held = await self.hold()
        return held.model_copy(update={"action": "orbit", "reached": held.ok, "reason": held.reason})

    async def _orbit_waypoints(
        self,
        lat: float,
        lon: float,
        radius_m: float,
        turns: float,
        alt_m: float | None,
        speed_mps: float | None,
        direction: float,
        deadline: float,
    ) -> FlightResult:
        started = time.monotonic()
        with self._lock:
            s = self._state
            known = s.lat_deg is not None and s.lon_deg is not None
            here = local_offset(lat, lon, s.lat_deg or 0.0, s.lon_deg or 0.0) if known else None
        if here is None:
            op = self._begin("orbit")
            return self._result(op, "failed", reason="no position from the vehicle")
        start_angle = math.atan2(here[1], here[0])
        per_turn = min(72, max(8, math.ceil(2.0 * math.pi * radius_m / 8.0)))
        count = max(1, math.ceil(turns * per_turn))
        step = direction * turns * 2.0 * math.pi / count
        note = f"the vehicle does not support DO_ORBIT: flown as {count + 1} waypoints on the circle"
        result: FlightResult | None = None
        for k in range(count + 1):
            angle = start_angle + k * step
            wlat, wlon = offset_position(lat, lon, radius_m * math.cos(angle), radius_m * math.sin(angle))
            left = deadline - time.monotonic()
            result = await self.goto(
                wlat,
                wlon,
                alt_m,
                speed_mps=speed_mps,
                timeout_s=max(0.0, left),
                acceptance_m=max(1.5, min(3.0, 0.15 * radius_m)),
                alt_tolerance_m=2.0,
                action="orbit",
            )
            if not result.ok:
                why = f"waypoint {k + 1}/{count + 1}: {result.reason}"
                return result.model_copy(update={"reason": f"{note}; {why}", "elapsed_s": time.monotonic() - started})
        assert result is not None
        return result.model_copy(update={"reason": note, "elapsed_s": time.monotonic() - started})

    async def wait_telemetry(self, timeout_s: float = 5.0) -> Telemetry | None:
        """The telemetry once a position has arrived (None after ``timeout_s``)."""
        found = await self._wait(lambda _m: True if self._state.lat_deg is not None else None, timeout_s)
        return self.telemetry if found else None
