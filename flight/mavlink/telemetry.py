"""Telemetry: the streamed and requested messages the vehicle builds from the simulator's state.

Why: keeps :mod:`flight.mavlink.vehicle` to the link (socket, dispatch, pacing). :class:`TelemetryBuilders` is a mixin
of :class:`~flight.mavlink.vehicle.MavlinkVehicle`; each ``*_fields`` builder returns a message's fields in the order
pymavlink's ``*_encode`` takes them, and a :class:`WireCodec` turns them into the message object (requests) or
straight into the bytes on the wire (streams). Builders read the simulator's raw state (``sim.truth()``) and battery
rather than the :class:`~flight.sim.VehicleState` snapshot: the same values, without validating a 23-field snapshot
several times a second on every stream.

Facts relied on (MAVLink ``common.xml`` via pymavlink's generated ``dialects/v20/common.py``):

* HEARTBEAT: MAV_TYPE_QUADROTOR 2, MAV_AUTOPILOT_PX4 12, MAV_STATE_STANDBY 3 disarmed, ACTIVE 4 armed,
  CRITICAL 5 with the battery below ``BAT_CRIT_THR``; mode encoding in :mod:`flight.px4`.
* BATTERY_STATUS: unknown cell voltages are the total in ``voltages[0]`` and UINT16_MAX in the others; unknown
  temperature is INT16_MAX; ``energy_consumed`` -1 is unknown.
* SYS_STATUS: MAV_SYS_STATUS_PREARM_CHECK (``0x10000000``) is "pre-arm check status, always healthy when armed";
  PX4 reports it present and enabled, and healthy when arming would be allowed. MAVSDK's ``Health.is_armable``
  reads exactly this bit, so without it a MAVSDK client sees a vehicle that can never be armed.
* WIND_COV 231: ``wind_x``/``wind_y``/``wind_z`` the wind in m/s, NED (where the air moves towards),
  ``var_horiz``/``var_vert`` its variability, ``wind_alt`` metres above mean sea level, accuracies (NaN: unknown).
* AUTOPILOT_VERSION ``flight_sw_version`` is ``major << 24 | minor << 16 | patch << 8 | type`` (type 255:
  release); we report PX4 1.14.0, the release whose behaviour is mimicked.
* A MAVLink 2 frame (pymavlink ``MAVLink_message._pack``, unsigned): ``0xFD``, payload length, incompat flags 0,
  compat flags 0, sequence, system id, component id, message id (24 bits, little-endian), the payload packed in the
  wire order of the fields (``ordered_fieldnames``) with its trailing zero bytes dropped (at least one byte is
  kept), then the X.25 CRC of everything after ``0xFD`` followed by the message's ``crc_extra`` byte.
"""

from __future__ import annotations

import functools
import inspect
import math
import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_AUTOPILOT_PX4,
    MAV_STATE_ACTIVE,
    MAV_STATE_CRITICAL,
    MAV_STATE_STANDBY,
    MAV_TYPE_QUADROTOR,
)

from agentic_core.contracts.telemetry import TelemetrySample
from flight.client.telemetry import LANDED_STATES, PX4_MODES
from flight.mavlink.navigator import MIN_GPS_SATELLITES, Navigator
from flight.mavlink.params import ParamStore
from flight.px4 import FlightMode, base_mode
from flight.sim import Simulator

PX4_VERSION = (1, 14, 0)
FIRMWARE_VERSION_TYPE_OFFICIAL = 255
CAPABILITIES = (
    mavlink2.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink2.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    | mavlink2.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)
SENSORS = (
    mavlink2.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | mavlink2.MAV_SYS_STATUS_SENSOR_3D_MAG
    | mavlink2.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | mavlink2.MAV_SYS_STATUS_SENSOR_GPS
    | mavlink2.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | mavlink2.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | mavlink2.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | mavlink2.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    | mavlink2.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | mavlink2.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | mavlink2.MAV_SYS_STATUS_SENSOR_BATTERY
    | mavlink2.MAV_SYS_STATUS_PREARM_CHECK
)
UINT16_MAX = 0xFFFF
INT16_MAX = 0x7FFF


@dataclass(slots=True)
class LinkStats:
    """Counters of the UDP link."""

    rx_datagrams: int = 0
    rx_messages: int = 0
    rx_dropped: int = 0
    """Datagrams that held no valid MAVLink message (garbage, truncated, bad CRC)."""
    rx_bad_chunks: int = 0
    """Bad-data chunks reported by the parser (a datagram can hold several, and valid messages besides)."""
    rx_refused: int = 0
    """Datagrams whose every message the guard refused (unsigned, badly signed, replayed: :mod:`flight.signing`)."""
    tx_messages: int = 0
    tx_errors: int = 0


Fields = tuple[Any, ...]
"""A message's field values, in the order of its ``fieldnames`` (the arguments of pymavlink's ``*_encode``)."""

_HEADER = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")
_MAGIC_V2 = 0xFD


def _x25_slow(data: bytes) -> int:
    return int(mavlink2.x25crc(data).crc)


_mcrf4xx: Callable[..., int] | None = getattr(mavlink2, "mcrf4xx", None)
_x25: Callable[[bytes], int] = _x25_slow if _mcrf4xx is None else functools.partial(_mcrf4xx, initial=0xFFFF)
"""The X.25 CRC (CRC-16/MCRF4XX) of a frame, straight from ``fastcrc`` where pymavlink uses it."""


class WireCodec:
    """One MAVLink 2 message type: its fields as a pymavlink message object (:meth:`message`) or packed straight
    into the bytes ``message(fields).pack(mav)`` would give (:meth:`pack`).

    Why: the streams send thousands of messages per simulated minute, and building each as an object and packing it
    through pymavlink's generic path costs more than several physics steps. Fields left out take the message's
    defaults (its MAVLink 2 extensions); messages with array fields, and signed links, take pymavlink's own path.
    """

    def __init__(self, cls: type[mavlink2.MAVLink_message]) -> None:
        self.cls = cls
        names: list[str] = list(cls.fieldnames)
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        if [p.name for p in params] != names:  # pragma: no cover - pymavlink's generated constructors take them so
            raise ValueError(f"{cls.__name__}: constructor arguments are not its fields")
        self._required = sum(p.default is inspect.Parameter.empty for p in params)
        self._defaults: Fields = tuple(p.default for p in params)
        order = [names.index(name) for name in cls.ordered_fieldnames]
        self._order: tuple[int, ...] | None = None if order == list(range(len(names))) else tuple(order)
        self._direct = not any(cls.array_lengths)
        self._payload = cls.unpacker
        self._id_low, self._id_high = cls.id & 0xFFFF, cls.id >> 16
        self._crc_extra = bytes((cls.crc_extra,))

    def message(self, fields: Fields) -> Any:
        """The pymavlink message object (what ``mav.<name>_encode(*fields)`` returns)."""
        return self.cls(*fields)

    def pack(self, mav: mavlink2.MAVLink, fields: Fields) -> bytes:
        """The frame ``mav`` would send for these fields now (with its current sequence number)."""
        if not self._direct or mav.signing.sign_outgoing:
            return bytes(self.message(fields).pack(mav))
        if len(fields) < len(self._defaults):
            if len(fields) < self._required:
                raise TypeError(f"{self.cls.__name__} needs {self._required} fields, got {len(fields)}")
            fields = fields + self._defaults[len(fields) :]
        if self._order is not None:
            fields = tuple([fields[i] for i in self._order])
        payload = self._payload.pack(*fields).rstrip(b"\0") or b"\0"
        header = _HEADER.pack(
            _MAGIC_V2, len(payload), 0, 0, mav.seq, mav.srcSystem, mav.srcComponent, self._id_low, self._id_high
        )
        frame = header + payload
        return frame + _CRC.pack(_x25(frame[1:] + self._crc_extra))


HEARTBEAT = WireCodec(mavlink2.MAVLink_heartbeat_message)
SYS_STATUS = WireCodec(mavlink2.MAVLink_sys_status_message)
BATTERY_STATUS = WireCodec(mavlink2.MAVLink_battery_status_message)
ATTITUDE = WireCodec(mavlink2.MAVLink_attitude_message)
GLOBAL_POSITION_INT = WireCodec(mavlink2.MAVLink_global_position_int_message)
LOCAL_POSITION_NED = WireCodec(mavlink2.MAVLink_local_position_ned_message)
GPS_RAW_INT = WireCodec(mavlink2.MAVLink_gps_raw_int_message)
EXTENDED_SYS_STATE = WireCodec(mavlink2.MAVLink_extended_sys_state_message)
HOME_POSITION = WireCodec(mavlink2.MAVLink_home_position_message)
AUTOPILOT_VERSION = WireCodec(mavlink2.MAVLink_autopilot_version_message)
MISSION_CURRENT = WireCodec(mavlink2.MAVLink_mission_current_message)
WIND_COV = WireCodec(mavlink2.MAVLink_wind_cov_message)


MODE_NAMES: dict[FlightMode, str] = {mode: PX4_MODES[(mode.main_mode, mode.sub_mode)] for mode in FlightMode}
"""Each mode by the name a client decodes from HEARTBEAT (:data:`flight.client.telemetry.PX4_MODES`)."""
_new_sample = TelemetrySample.model_construct


def _clamp_int(x: float, lo: int, hi: int) -> int:
    if not _isfinite(x):
        return lo
    r = round(x)
    return lo if r < lo else hi if r > hi else r


_isfinite = math.isfinite


class TelemetryBuilders:
    """Message builders; mixed into the vehicle, which provides the attributes below. Each ``*_fields`` method
    returns the fields for its message's :class:`WireCodec`."""

    sim: Simulator
    navigator: Navigator
    params: ParamStore
    stats: LinkStats
    system_id: int
    _mav: mavlink2.MAVLink

    def _time_boot_ms(self) -> int:
        return round(self.sim.time_s * 1000.0) & 0xFFFFFFFF

    def _time_usec(self) -> int:
        return round(self.sim.time_s * 1e6)

    def _battery_fraction(self) -> float:
        return float(self.sim.battery.percent) / 100.0

    def _heartbeat_fields(self) -> Fields:
        armed = self.sim.armed
        if self._battery_fraction() <= self.params["BAT_CRIT_THR"]:
            status = MAV_STATE_CRITICAL
        else:
            status = MAV_STATE_ACTIVE if armed else MAV_STATE_STANDBY
        mode = self.navigator.mode
        return (MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_PX4, base_mode(mode, armed), mode.custom_mode, status, 3)

    def _prearm_ok(self) -> bool:
        """Whether arming would pass the navigator's checks (3D fix with enough satellites, battery above
        ``BAT_LOW_THR`` and not depleted, on the ground); always true when armed, as MAVLink defines the bit."""
        sim = self.sim
        if sim.armed:
            return True
        fix = sim.gps_fix()
        truth = sim.truth()
        return (
            fix.fix_type >= 3
            and fix.satellites >= MIN_GPS_SATELLITES
            and self._battery_fraction() > self.params["BAT_LOW_THR"]
            and not sim.battery.depleted
            and truth.on_ground
        )

    def _sys_status_fields(self) -> Fields:
        b = self.sim.battery
        enabled = SENSORS if self.sim.armed else SENSORS & ~mavlink2.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
        health = SENSORS if self._prearm_ok() else SENSORS & ~mavlink2.MAV_SYS_STATUS_PREARM_CHECK
        return (
            SENSORS,
            enabled,
            health,
            0,
            _clamp_int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1),
            _clamp_int(b.current_a * 100.0, -1, 32767),
            _clamp_int(b.percent, 0, 100),
            0,
            min(self.stats.rx_dropped + self.stats.rx_refused, UINT16_MAX),
            0,
            0,
            0,
            0,
        )

    def _battery_status_fields(self) -> Fields:
        b = self.sim.battery
        frac = self._battery_fraction()
        if frac <= self.params["BAT_CRIT_THR"]:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_CRITICAL
        elif frac <= self.params["BAT_LOW_THR"]:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_LOW
        else:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_OK
        voltages = [_clamp_int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1)] + [UINT16_MAX] * 9
        return (
            0,
            mavlink2.MAV_BATTERY_FUNCTION_ALL,
            mavlink2.MAV_BATTERY_TYPE_LIPO,
            INT16_MAX,
            voltages,
            _clamp_int(b.current_a * 100.0, -1, 32767),
            _clamp_int(b.used_mah, 0, 2**31 - 1),
            -1,
            _clamp_int(b.percent, 0, 100),
            0,
            charge,
        )

    def _attitude_fields(self) -> Fields:
        t = self.sim.truth()
        return (self._time_boot_ms(), t.roll_rad, t.pitch_rad, t.yaw_rad, t.p_rps, t.q_rps, t.r_rps)

    def _global_position_int_fields(self) -> Fields:
        s = self.sim.truth()
        hdg = round(math.degrees(s.yaw_rad) % 360.0 * 100.0) % 36000
        return (
            self._time_boot_ms(),
            round(s.lat_deg * 1e7),
            round(s.lon_deg * 1e7),
            round(s.alt_msl_m * 1000.0),
            round(-s.down_m * 1000.0),
            _clamp_int(s.vn_mps * 100.0, -32768, 32767),
            _clamp_int(s.ve_mps * 100.0, -32768, 32767),
            _clamp_int(s.vd_mps * 100.0, -32768, 32767),
            hdg,
        )

    def _local_position_ned_fields(self) -> Fields:
        s = self.sim.truth()
        return (self._time_boot_ms(), s.north_m, s.east_m, s.down_m, s.vn_mps, s.ve_mps, s.vd_mps)

    def _gps_raw_int_fields(self) -> Fields:
        f = self.sim.gps_fix()
        vel = math.hypot(f.vn_mps, f.ve_mps)
        cog = round(math.degrees(math.atan2(f.ve_mps, f.vn_mps)) % 360.0 * 100.0) % 36000 if vel > 0.1 else UINT16_MAX
        alt_mm = round(f.alt_msl_m * 1000.0)
        return (
            self._time_usec(),
            f.fix_type,
            round(f.lat_deg * 1e7),
            round(f.lon_deg * 1e7),
            alt_mm,
            _clamp_int(f.eph_m * 100.0, 0, UINT16_MAX - 1),
            _clamp_int(f.epv_m * 100.0, 0, UINT16_MAX - 1),
            _clamp_int(vel * 100.0, 0, UINT16_MAX - 1),
            cog,
            min(f.satellites, 254),
            alt_mm,
            _clamp_int(f.eph_m * 1000.0, 0, 2**32 - 1),
            _clamp_int(f.epv_m * 1000.0, 0, 2**32 - 1),
        )

    def _wind_cov_fields(self) -> Fields:
        """The wind estimate: the simulator's steady wind (an estimator's smoothed value, not the gusts), with the
        gusts' standard deviation as its variability; accuracy unknown (NaN)."""
        w = self.sim.wind
        nan = math.nan
        gusts = w.gust_std_mps
        return (self._time_usec(), w.north_mps, w.east_mps, w.down_mps, gusts, 0.5 * gusts,
                self.sim.truth().alt_msl_m, nan, nan)  # fmt: skip

    def _extended_sys_state_fields(self) -> Fields:
        return (mavlink2.MAV_VTOL_STATE_UNDEFINED, self.navigator.landed_state())

    def _home_position_fields(self) -> Fields:
        home = self.sim.environment.home
        return (
            round(home.lat_deg * 1e7),
            round(home.lon_deg * 1e7),
            round(home.alt_msl_m * 1000.0),
            0.0,
            0.0,
            0.0,
            [1.0, 0.0, 0.0, 0.0],
            0.0,
            0.0,
            0.0,
            self._time_usec(),
        )

    def _autopilot_version_fields(self) -> Fields:
        major, minor, patch = PX4_VERSION
        version = major << 24 | minor << 16 | patch << 8 | FIRMWARE_VERSION_TYPE_OFFICIAL
        return (CAPABILITIES, version, version, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, self.system_id)

    def telemetry_sample(self) -> TelemetrySample:
        """The state this vehicle reports now, as one :class:`TelemetrySample`: the values its GLOBAL_POSITION_INT,
        LOCAL_POSITION_NED, ATTITUDE, SYS_STATUS, HEARTBEAT, EXTENDED_SYS_STATE, GPS_RAW_INT and WIND_COV builders
        put on the wire (before the wire's integer rounding), on the vehicle's clock. Built unvalidated
        (``model_construct``): every value comes from the builders' own sources, and it is built every tick while
        someone listens."""
        s = self.sim.truth()
        sim = self.sim
        return _new_sample(
            time_s=sim.time_s,
            lat_deg=s.lat_deg,
            lon_deg=s.lon_deg,
            alt_m=-s.down_m,
            alt_msl_m=s.alt_msl_m,
            north_m=s.north_m,
            east_m=s.east_m,
            down_m=s.down_m,
            vn_mps=s.vn_mps,
            ve_mps=s.ve_mps,
            vd_mps=s.vd_mps,
            roll_deg=math.degrees(s.roll_rad),
            pitch_deg=math.degrees(s.pitch_rad),
            yaw_deg=math.degrees(s.yaw_rad) % 360.0,
            battery_pct=sim.battery.percent,
            mode=MODE_NAMES[self.navigator.mode],
            armed=sim.armed,
            landed_state=LANDED_STATES.get(self.navigator.landed_state(), "unknown"),
            gps_fix_type=0 if sim.gps_lost else 3,
            gps_satellites=0 if sim.gps_lost else sim.gps.settings.satellites,
            wind_north_mps=sim.wind.north_mps,
            wind_east_mps=sim.wind.east_mps,
        )
