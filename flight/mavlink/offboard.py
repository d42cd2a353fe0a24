"""Offboard setpoints: SET_POSITION_TARGET_LOCAL_NED (84) and SET_POSITION_TARGET_GLOBAL_INT (86), decoded.

Why: MAVSDK's ``offboard`` plugin, MAVROS and scripts fly PX4 in Offboard mode by streaming these messages; the
navigator flies the latest one and leaves Offboard when the stream stops (see
:meth:`flight.mavlink.navigator.Navigator.update`).

Facts relied on (MAVLink ``common.xml`` via pymavlink's ``dialects/v20/common.py``; PX4 user guide, "Offboard
Mode", v1.14):

* POSITION_TARGET_TYPEMASK bits *ignore* a field: X 1, Y 2, Z 4, VX 8, VY 16, VZ 32, AX 64, AY 128, AZ 256,
  FORCE_SET 512, YAW 1024, YAW_RATE 2048.
* Local frames: MAV_FRAME_LOCAL_NED 1 (our local origin is home, as LOCAL_POSITION_NED reports),
  LOCAL_OFFSET_NED 7 (relative to the current position), BODY_NED 8 / BODY_OFFSET_NED 9 / BODY_FRD 12 (relative
  to the current position, rotated by the heading). Global frames as in :mod:`flight.mavlink.commands`.
* PX4 multicopters fly position, velocity, and position with velocity as feed-forward; acceleration and thrust
  setpoints are not flown here. A position with a velocity is flown as the position (no feed-forward in our
  controller). Yaw rate is ignored.
* Offboard must be receiving setpoints before it can be engaged and is left when they stop for ``COM_OF_LOSS_T``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_FRAME_BODY_FRD,
    MAV_FRAME_BODY_NED,
    MAV_FRAME_BODY_OFFSET_NED,
    MAV_FRAME_LOCAL_NED,
    MAV_FRAME_LOCAL_OFFSET_NED,
)

from agentic_core.contracts.errors import AgenticUAVError
from flight.sim import Simulator, geodetic_to_ned

IGNORE_X, IGNORE_Y, IGNORE_Z = 1, 2, 4
IGNORE_VX, IGNORE_VY, IGNORE_VZ = 8, 16, 32
IGNORE_YAW = 1024
IGNORE_POSITION = IGNORE_X | IGNORE_Y | IGNORE_Z
IGNORE_VELOCITY = IGNORE_VX | IGNORE_VY | IGNORE_VZ

_BODY_FRAMES = frozenset({MAV_FRAME_BODY_NED, MAV_FRAME_BODY_OFFSET_NED, MAV_FRAME_BODY_FRD})
_LOCAL_FRAMES = frozenset({MAV_FRAME_LOCAL_NED, MAV_FRAME_LOCAL_OFFSET_NED}) | _BODY_FRAMES
_AMSL_FRAMES = frozenset({0, 5})
_RELATIVE_FRAMES = frozenset({3, 6, 10, 11})

Vec3 = tuple[float, float, float]


class SetpointRejected(AgenticUAVError, ValueError):
    """A setpoint message that cannot be flown (frame, mask or values)."""


@dataclass(frozen=True, slots=True)
class OffboardSetpoint:
    """A decoded setpoint: a NED position relative to home, else a NED velocity; yaw None keeps the heading."""

    position: Vec3 | None
    velocity: Vec3 | None
    yaw_rad: float | None


def _finite(*xs: float) -> bool:
    return all(math.isfinite(x) for x in xs)


def _yaw(msg: Any) -> float | None:
    if msg.type_mask & IGNORE_YAW or not _finite(msg.yaw):
        return None
    return float(msg.yaw)


def _velocity(msg: Any, heading_rad: float | None) -> Vec3 | None:
    if msg.type_mask & IGNORE_VELOCITY == IGNORE_VELOCITY:
        return None
    if msg.type_mask & IGNORE_VELOCITY:
        raise SetpointRejected("velocity needs all of vx, vy, vz")
    vx, vy, vz = float(msg.vx), float(msg.vy), float(msg.vz)
    if not _finite(vx, vy, vz):
        raise SetpointRejected("velocity is not a number")
    if heading_rad is not None:
        c, s = math.cos(heading_rad), math.sin(heading_rad)
        vx, vy = c * vx - s * vy, s * vx + c * vy
    return vx, vy, vz


def _check_position_mask(mask: int) -> bool:
    """True if the position is given; raises when only part of it is."""
    ignored = mask & IGNORE_POSITION
    if ignored == IGNORE_POSITION:
        return False
    if ignored:
        raise SetpointRejected("position needs all of x, y, z")
    return True


def _result(position: Vec3 | None, velocity: Vec3 | None, yaw: float | None) -> OffboardSetpoint:
    if position is None and velocity is None:
        raise SetpointRejected("only position and velocity setpoints are flown")
    return OffboardSetpoint(position, None if position is not None else velocity, yaw)


def decode_local_ned(msg: Any, sim: Simulator) -> OffboardSetpoint:
    """SET_POSITION_TARGET_LOCAL_NED as a setpoint; raises :class:`SetpointRejected`."""
    frame = int(msg.coordinate_frame)
    if frame not in _LOCAL_FRAMES:
        raise SetpointRejected(f"frame {frame} not supported")
    s = sim.state()
    heading = s.yaw_rad if frame in _BODY_FRAMES else None
    position: Vec3 | None = None
    if _check_position_mask(int(msg.type_mask)):
        x, y, z = float(msg.x), float(msg.y), float(msg.z)
        if not _finite(x, y, z):
            raise SetpointRejected("position is not a number")
        if frame == MAV_FRAME_LOCAL_NED:
            position = (x, y, z)
        else:
            if heading is not None:
                c, sn = math.cos(heading), math.sin(heading)
                x, y = c * x - sn * y, sn * x + c * y
            position = (s.north_m + x, s.east_m + y, s.down_m + z)
    return _result(position, _velocity(msg, heading), _yaw(msg))


def decode_global_int(msg: Any, sim: Simulator) -> OffboardSetpoint:
    """SET_POSITION_TARGET_GLOBAL_INT as a setpoint; raises :class:`SetpointRejected`."""
    frame = int(msg.coordinate_frame)
    if frame not in _AMSL_FRAMES | _RELATIVE_FRAMES:
        raise SetpointRejected(f"frame {frame} not supported")
    position: Vec3 | None = None
    if _check_position_mask(int(msg.type_mask)):
        lat, lon, alt = msg.lat_int / 1e7, msg.lon_int / 1e7, float(msg.alt)
        if not (_finite(alt) and -90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            raise SetpointRejected("position out of range")
        home = sim.environment.home
        alt_msl = alt if frame in _AMSL_FRAMES else home.alt_msl_m + alt
        position = geodetic_to_ned(lat, lon, alt_msl, home.lat_deg, home.lon_deg, home.alt_msl_m)
    return _result(position, _velocity(msg, None), _yaw(msg))
