"""PX4 on the wire, for both ends of the link (the simulated vehicle and the agent's client): HEARTBEAT
``base_mode`` flags, the PX4 ``custom_mode`` word, and MAVLink's fixed-length text fields.

Why: every MAVLink client that knows PX4 (MAVSDK, QGroundControl, MAVProxy, pymavlink's ``mavutil``) reads the
vehicle's mode from HEARTBEAT.custom_mode and sets it with MAV_CMD_DO_SET_MODE (176), so the vehicle must speak
PX4's encoding exactly.

Facts relied on (checked in PX4-Autopilot's ``px4_custom_mode.h`` and pymavlink's generated ``common`` dialect):

* ``custom_mode`` is a little-endian ``uint32`` laid over ``{uint16 reserved; uint8 main_mode; uint8 sub_mode}``,
  so ``custom_mode = main_mode << 16 | sub_mode << 24``.
* Main modes: MANUAL 1, ALTCTL 2, POSCTL 3, AUTO 4, ACRO 5, OFFBOARD 6, STABILIZED 7, RATTITUDE 8.
* AUTO sub modes: READY 1, TAKEOFF 2, LOITER 3 (shown as "Hold"), MISSION 4, RTL 5, LAND 6, (7 retired),
  FOLLOW_TARGET 8, PRECLAND 9. Non-AUTO main modes use sub mode 0.
* ``base_mode`` flags (MAV_MODE_FLAG): CUSTOM_MODE_ENABLED 1, AUTO_ENABLED 4, GUIDED_ENABLED 8,
  STABILIZE_ENABLED 16, MANUAL_INPUT_ENABLED 64, SAFETY_ARMED 128. PX4 always sets CUSTOM_MODE_ENABLED; this module
  adds STABILIZE for every mode we fly, GUIDED for position-controlled modes and AUTO for the AUTO modes.
* DO_SET_MODE: param1 is the base mode (CUSTOM_MODE_ENABLED must be set for PX4 modes), param2 the main mode,
  param3 the sub mode.
"""

from __future__ import annotations

from enum import Enum, IntEnum

from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_MODE_FLAG_AUTO_ENABLED,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_GUIDED_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_MODE_FLAG_STABILIZE_ENABLED,
)


class MainMode(IntEnum):
    """PX4 ``PX4_CUSTOM_MAIN_MODE``."""

    MANUAL = 1
    ALTCTL = 2
    POSCTL = 3
    AUTO = 4
    ACRO = 5
    OFFBOARD = 6
    STABILIZED = 7
    RATTITUDE = 8


class AutoSubMode(IntEnum):
    """PX4 ``PX4_CUSTOM_SUB_MODE_AUTO``."""

    READY = 1
    TAKEOFF = 2
    LOITER = 3
    MISSION = 4
    RTL = 5
    LAND = 6
    FOLLOW_TARGET = 8
    PRECLAND = 9


class FlightMode(Enum):
    """The modes this vehicle flies, each with its PX4 (main, sub) pair."""

    HOLD = (MainMode.AUTO, AutoSubMode.LOITER)
    POSITION = (MainMode.POSCTL, 0)
    OFFBOARD = (MainMode.OFFBOARD, 0)
    MISSION = (MainMode.AUTO, AutoSubMode.MISSION)
    RTL = (MainMode.AUTO, AutoSubMode.RTL)
    LAND = (MainMode.AUTO, AutoSubMode.LAND)
    TAKEOFF = (MainMode.AUTO, AutoSubMode.TAKEOFF)

    @property
    def main_mode(self) -> int:
        return int(self.value[0])

    @property
    def sub_mode(self) -> int:
        return int(self.value[1])

    @property
    def custom_mode(self) -> int:
        return encode_custom_mode(self.main_mode, self.sub_mode)

    @classmethod
    def from_px4(cls, main_mode: int, sub_mode: int) -> FlightMode | None:
        """The mode for a PX4 (main, sub) pair, or None if this vehicle does not fly it.

        POSCTL with sub mode 1 (orbit) is not flown.
        """
        for mode in cls:
            if mode.main_mode == main_mode and mode.sub_mode == sub_mode:
                return mode
        return None


def encode_custom_mode(main_mode: int, sub_mode: int = 0) -> int:
    """HEARTBEAT.custom_mode for a PX4 main/sub mode pair."""
    if not (0 <= main_mode <= 0xFF and 0 <= sub_mode <= 0xFF):
        raise ValueError("main and sub modes are bytes")
    return (main_mode << 16) | (sub_mode << 24)


def decode_custom_mode(custom_mode: int) -> tuple[int, int]:
    """(main_mode, sub_mode) from HEARTBEAT.custom_mode."""
    return (custom_mode >> 16) & 0xFF, (custom_mode >> 24) & 0xFF


def base_mode(mode: FlightMode, armed: bool) -> int:
    """HEARTBEAT.base_mode for ``mode``: custom mode enabled, armed flag, and the flags that describe the mode."""
    flags = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MAV_MODE_FLAG_STABILIZE_ENABLED | MAV_MODE_FLAG_GUIDED_ENABLED
    if mode.main_mode == MainMode.AUTO:
        flags |= MAV_MODE_FLAG_AUTO_ENABLED
    if armed:
        flags |= MAV_MODE_FLAG_SAFETY_ARMED
    return int(flags)


def mavlink_text(field: bytes | str) -> str:
    """A fixed-length MAVLink char field (STATUSTEXT.text, PARAM_VALUE.param_id) as text, without its NUL padding."""
    if isinstance(field, bytes):
        field = field.decode("utf-8", "replace")
    return str(field).split("\x00", 1)[0]
