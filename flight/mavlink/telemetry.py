"""Telemetry: the streamed and requested messages the vehicle builds from the simulator's state.

Why: keeps :mod:`flight.mavlink.vehicle` to the link (socket, dispatch, pacing). :class:`TelemetryBuilders` is a mixin
of :class:`~flight.mavlink.vehicle.MavlinkVehicle`; each builder returns a message ready to pack. Builders read the
simulator's raw state (``sim.truth()``) and battery rather than the :class:`~flight.sim.VehicleState` snapshot: the
same values, without validating a 23-field snapshot several times a second on every stream.

Facts relied on (MAVLink ``common.xml`` via pymavlink's generated ``dialects/v20/common.py``):

* HEARTBEAT: MAV_TYPE_QUADROTOR 2, MAV_AUTOPILOT_PX4 12, MAV_STATE_STANDBY 3 disarmed, ACTIVE 4 armed,
  CRITICAL 5 with the battery below ``BAT_CRIT_THR``; mode encoding in :mod:`flight.px4`.
* BATTERY_STATUS: unknown cell voltages are the total in ``voltages[0]`` and UINT16_MAX in the others; unknown
  temperature is INT16_MAX; ``energy_consumed`` -1 is unknown.
* SYS_STATUS: MAV_SYS_STATUS_PREARM_CHECK (``0x10000000``) is "pre-arm check status, always healthy when armed";
  PX4 reports it present and enabled, and healthy when arming would be allowed. MAVSDK's ``Health.is_armable``
  reads exactly this bit, so without it a MAVSDK client sees a vehicle that can never be armed.
* AUTOPILOT_VERSION ``flight_sw_version`` is ``major << 24 | minor << 16 | patch << 8 | type`` (type 255:
  release); we report PX4 1.14.0, the release whose behaviour is mimicked.
"""

from __future__ import annotations

import math
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

from flight.mavlink.navigator import MIN_GPS_SATELLITES, Navigator
from flight.mavlink.params import ParamStore
from flight.px4 import base_mode
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
    tx_messages: int = 0
    tx_errors: int = 0


def _clamp_int(x: float, lo: int, hi: int) -> int:
    if not math.isfinite(x):
        return lo
    return max(lo, min(hi, round(x)))


class TelemetryBuilders:
    """Message builders; mixed into the vehicle, which provides the attributes below."""

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

    def _heartbeat(self) -> Any:
        armed = self.sim.armed
        if self._battery_fraction() <= self.params["BAT_CRIT_THR"]:
            status = MAV_STATE_CRITICAL
        else:
            status = MAV_STATE_ACTIVE if armed else MAV_STATE_STANDBY
        mode = self.navigator.mode
        return self._mav.heartbeat_encode(
            MAV_TYPE_QUADROTOR, MAV_AUTOPILOT_PX4, base_mode(mode, armed), mode.custom_mode, status, 3
        )

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

    def _sys_status(self) -> Any:
        b = self.sim.battery
        enabled = SENSORS if self.sim.armed else SENSORS & ~mavlink2.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
        health = SENSORS if self._prearm_ok() else SENSORS & ~mavlink2.MAV_SYS_STATUS_PREARM_CHECK
        return self._mav.sys_status_encode(
            SENSORS,
            enabled,
            health,
            0,
            _clamp_int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1),
            _clamp_int(b.current_a * 100.0, -1, 32767),
            _clamp_int(b.percent, 0, 100),
            0,
            min(self.stats.rx_dropped, UINT16_MAX),
            0,
            0,
            0,
            0,
        )

    def _battery_status(self) -> Any:
        b = self.sim.battery
        frac = self._battery_fraction()
        if frac <= self.params["BAT_CRIT_THR"]:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_CRITICAL
        elif frac <= self.params["BAT_LOW_THR"]:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_LOW
        else:
            charge = mavlink2.MAV_BATTERY_CHARGE_STATE_OK
        voltages = [_clamp_int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1)] + [UINT16_MAX] * 9
        return self._mav.battery_status_encode(
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

    def _attitude(self) -> Any:
        t = self.sim.truth()
        return self._mav.attitude_encode(
            self._time_boot_ms(), t.roll_rad, t.pitch_rad, t.yaw_rad, t.p_rps, t.q_rps, t.r_rps
        )

    def _global_position_int(self) -> Any:
        s = self.sim.truth()
        hdg = round(math.degrees(s.yaw_rad) % 360.0 * 100.0) % 36000
        return self._mav.global_position_int_encode(
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

    def _local_position_ned(self) -> Any:
        s = self.sim.truth()
        return self._mav.local_position_ned_encode(
            self._time_boot_ms(), s.north_m, s.east_m, s.down_m, s.vn_mps, s.ve_mps, s.vd_mps
        )

    def _gps_raw_int(self) -> Any:
        f = self.sim.gps_fix()
        vel = math.hypot(f.vn_mps, f.ve_mps)
        cog = round(math.degrees(math.atan2(f.ve_mps, f.vn_mps)) % 360.0 * 100.0) % 36000 if vel > 0.1 else UINT16_MAX
        alt_mm = round(f.alt_msl_m * 1000.0)
        return self._mav.gps_raw_int_encode(
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

    def _extended_sys_state(self) -> Any:
        return self._mav.extended_sys_state_encode(mavlink2.MAV_VTOL_STATE_UNDEFINED, self.navigator.landed_state())

    def _home_position(self) -> Any:
        home = self.sim.environment.home
        return self._mav.home_position_encode(
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

    def _autopilot_version(self) -> Any:
        major, minor, patch = PX4_VERSION
        version = major << 24 | minor << 16 | patch << 8 | FIRMWARE_VERSION_TYPE_OFFICIAL
        return self._mav.autopilot_version_encode(
            CAPABILITIES, version, version, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, self.system_id
        )
