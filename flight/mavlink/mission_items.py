"""Mission items on the vehicle: decoding MISSION_ITEM / MISSION_ITEM_INT into what is stored, and back.

Why: the transfer state machines (:mod:`flight.mavlink.mission`) only move items; whether an item is acceptable,
how its coordinates are read and how it is written back on download are the same for upload, download and
execution, so they live here, once. :class:`StoredItem` is what the vehicle keeps: a global item's position in
degrees, a non-positional item's param5/param6 as they came.

Behaviour kept from PX4 (``src/modules/mavlink/mavlink_mission.cpp``, ``parse_mavlink_mission_item`` and
``format_mavlink_mission_item``, read in the PX4-Autopilot repository):

* Frames: MAV_FRAME_GLOBAL 0 (altitude above mean sea level) and GLOBAL_RELATIVE_ALT 3 (above home) are read from
  either message; GLOBAL_INT 5 and GLOBAL_RELATIVE_ALT_INT 6 only from MISSION_ITEM_INT. In MISSION_ITEM_INT, x/y
  are degrees×1e7 whatever the global frame; in MISSION_ITEM they are degrees as floats. MAV_FRAME_MISSION 2 is for
  items without a position (x/y/z are param5..7 as sent). Any other frame (local, terrain) is
  MAV_MISSION_UNSUPPORTED_FRAME.
* Commands: each frame class has its own list (:data:`GLOBAL_COMMANDS`, :data:`NON_POSITIONAL_COMMANDS`); anything
  else is MAV_MISSION_UNSUPPORTED. NAV_RETURN_TO_LAUNCH, DO_CHANGE_SPEED, DO_GRIPPER, DO_JUMP, delays and the
  camera/mount items are non-positional (frame 2); NAV_WAYPOINT, NAV_TAKEOFF, NAV_LAND, the loiters and the fence
  and rally items are global. NAV_ROI / DO_SET_ROI take only the ROI modes PX4 takes (else
  MAV_MISSION_INVALID_PARAM1).
* A fence or rally item in a flight-plan mission is MAV_MISSION_ERROR; a polygon vertex whose vertex count
  (param1) is below 3 is MAV_MISSION_ERROR.
* On download an item goes back in the message kind it was asked for: from MISSION_REQUEST_INT as
  MISSION_ITEM_INT with frame GLOBAL_RELATIVE_ALT_INT 6 or GLOBAL_INT 5, from MISSION_REQUEST as MISSION_ITEM with
  frame GLOBAL_RELATIVE_ALT 3 or GLOBAL 0. ``current`` is 1 for the current mission item.

Ours, not PX4's: DO_SET_SERVO is accepted in missions (PX4's current list has DO_SET_ACTUATOR instead; we keep
DO_SET_SERVO because it is this vehicle's payload release); a latitude or longitude out of range is
MAV_MISSION_INVALID_PARAM5_X / _PARAM6_Y and a non-finite one is refused likewise, an altitude beyond
±:data:`MAX_ABS_ALTITUDE_M` is MAV_MISSION_INVALID_PARAM7, a fence circle without a positive radius is
MAV_MISSION_INVALID_PARAM1 (PX4 takes any value); in a geofence plan only fence items are accepted and in a rally
plan only rally points (PX4 checks only the other way round); every parameter is kept as sent (PX4 keeps only those
its item struct has, and returns zeros for the rest).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import common as mavlink2
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_CONDITION_DELAY,
    MAV_CMD_CONDITION_DISTANCE,
    MAV_CMD_CONDITION_GATE,
    MAV_CMD_DO_AUTOTUNE_ENABLE,
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_CONTROL_VIDEO,
    MAV_CMD_DO_DIGICAM_CONTROL,
    MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
    MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_DO_JUMP,
    MAV_CMD_DO_LAND_START,
    MAV_CMD_DO_MOUNT_CONFIGURE,
    MAV_CMD_DO_MOUNT_CONTROL,
    MAV_CMD_DO_SET_ACTUATOR,
    MAV_CMD_DO_SET_CAM_TRIGG_DIST,
    MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL,
    MAV_CMD_DO_SET_HOME,
    MAV_CMD_DO_SET_ROI,
    MAV_CMD_DO_SET_ROI_LOCATION,
    MAV_CMD_DO_SET_ROI_NONE,
    MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET,
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_DO_TRIGGER_CONTROL,
    MAV_CMD_DO_VTOL_TRANSITION,
    MAV_CMD_DO_WINCH,
    MAV_CMD_IMAGE_START_CAPTURE,
    MAV_CMD_IMAGE_STOP_CAPTURE,
    MAV_CMD_NAV_DELAY,
    MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_FENCE_RETURN_POINT,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_LOITER_TO_ALT,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_RALLY_POINT,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_ROI,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_VTOL_LAND,
    MAV_CMD_NAV_VTOL_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_CMD_OBLIQUE_SURVEY,
    MAV_CMD_SET_CAMERA_FOCUS,
    MAV_CMD_SET_CAMERA_MODE,
    MAV_CMD_SET_CAMERA_SOURCE,
    MAV_CMD_VIDEO_START_CAPTURE,
    MAV_CMD_VIDEO_STOP_CAPTURE,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_MISSION,
    MAV_MISSION_ERROR,
    MAV_MISSION_INVALID_PARAM1,
    MAV_MISSION_INVALID_PARAM5_X,
    MAV_MISSION_INVALID_PARAM6_Y,
    MAV_MISSION_INVALID_PARAM7,
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
    MAV_MISSION_UNSUPPORTED,
    MAV_MISSION_UNSUPPORTED_FRAME,
    MAV_ROI_LOCATION,
    MAV_ROI_NONE,
    MAV_ROI_WPINDEX,
    MAV_ROI_WPNEXT,
)

from agentic_core.contracts.errors import AgenticUAVError

FENCE_POLYGON_COMMANDS = frozenset(
    {MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION, MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION}
)
FENCE_CIRCLE_COMMANDS = frozenset({MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION, MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION})
FENCE_COMMANDS = FENCE_POLYGON_COMMANDS | FENCE_CIRCLE_COMMANDS | {MAV_CMD_NAV_FENCE_RETURN_POINT}
RALLY_COMMANDS = frozenset({MAV_CMD_NAV_RALLY_POINT})

GLOBAL_COMMANDS = frozenset(
    {
        MAV_CMD_NAV_WAYPOINT,
        MAV_CMD_NAV_LOITER_UNLIM,
        MAV_CMD_NAV_LOITER_TIME,
        MAV_CMD_NAV_LAND,
        MAV_CMD_NAV_TAKEOFF,
        MAV_CMD_NAV_LOITER_TO_ALT,
        MAV_CMD_NAV_ROI,
        MAV_CMD_DO_SET_ROI,
        MAV_CMD_DO_SET_ROI_LOCATION,
        MAV_CMD_NAV_VTOL_TAKEOFF,
        MAV_CMD_NAV_VTOL_LAND,
        MAV_CMD_CONDITION_GATE,
        MAV_CMD_COMPONENT_ARM_DISARM,
        MAV_CMD_DO_AUTOTUNE_ENABLE,
    }
    | FENCE_COMMANDS
    | RALLY_COMMANDS
)
"""Commands PX4 accepts in a global frame (0, 3, 5, 6)."""

NON_POSITIONAL_COMMANDS = frozenset(
    {
        MAV_CMD_DO_JUMP,
        MAV_CMD_NAV_ROI,
        MAV_CMD_DO_SET_ROI,
        MAV_CMD_DO_WINCH,
        MAV_CMD_DO_GRIPPER,
        MAV_CMD_DO_CHANGE_SPEED,
        MAV_CMD_DO_SET_HOME,
        MAV_CMD_DO_LAND_START,
        MAV_CMD_DO_TRIGGER_CONTROL,
        MAV_CMD_DO_DIGICAM_CONTROL,
        MAV_CMD_DO_MOUNT_CONFIGURE,
        MAV_CMD_DO_MOUNT_CONTROL,
        MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW,
        MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE,
        MAV_CMD_SET_CAMERA_FOCUS,
        MAV_CMD_IMAGE_START_CAPTURE,
        MAV_CMD_IMAGE_STOP_CAPTURE,
        MAV_CMD_VIDEO_START_CAPTURE,
        MAV_CMD_VIDEO_STOP_CAPTURE,
        MAV_CMD_DO_CONTROL_VIDEO,
        MAV_CMD_DO_SET_CAM_TRIGG_DIST,
        MAV_CMD_OBLIQUE_SURVEY,
        MAV_CMD_DO_SET_CAM_TRIGG_INTERVAL,
        MAV_CMD_SET_CAMERA_MODE,
        MAV_CMD_SET_CAMERA_SOURCE,
        MAV_CMD_DO_VTOL_TRANSITION,
        MAV_CMD_NAV_DELAY,
        MAV_CMD_NAV_RETURN_TO_LAUNCH,
        MAV_CMD_DO_SET_ROI_WPNEXT_OFFSET,
        MAV_CMD_DO_SET_ROI_NONE,
        MAV_CMD_CONDITION_DELAY,
        MAV_CMD_CONDITION_DISTANCE,
        MAV_CMD_DO_SET_ACTUATOR,
        MAV_CMD_DO_AUTOTUNE_ENABLE,
        MAV_CMD_COMPONENT_ARM_DISARM,
        MAV_CMD_DO_SET_SERVO,  # ours: see the module docstring
    }
)
"""Commands PX4 accepts with MAV_FRAME_MISSION (no position)."""

POSITION_COMMANDS = frozenset(
    {
        MAV_CMD_NAV_WAYPOINT,
        MAV_CMD_NAV_LOITER_UNLIM,
        MAV_CMD_NAV_LOITER_TIME,
        MAV_CMD_NAV_LOITER_TO_ALT,
        MAV_CMD_NAV_LAND,
        MAV_CMD_NAV_TAKEOFF,
        MAV_CMD_NAV_VTOL_TAKEOFF,
        MAV_CMD_NAV_VTOL_LAND,
    }
)
"""Items the vehicle flies to, which must lie inside the geofence."""

_GLOBAL_FLOAT_FRAMES = frozenset({MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_RELATIVE_ALT})
_GLOBAL_INT_FRAMES = frozenset({MAV_FRAME_GLOBAL_INT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_RELATIVE_FRAMES = frozenset({MAV_FRAME_GLOBAL_RELATIVE_ALT, MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_ROI_MODES_GLOBAL = frozenset({MAV_ROI_LOCATION, MAV_ROI_NONE})
_ROI_MODES_NON_POSITIONAL = frozenset({MAV_ROI_NONE, MAV_ROI_WPNEXT, MAV_ROI_WPINDEX})
MIN_POLYGON_VERTICES = 3
MAX_ABS_ALTITUDE_M = 100_000.0


class ItemRejected(AgenticUAVError):
    """An item the vehicle will not store, with the MAV_MISSION_RESULT to answer."""

    def __init__(self, result: int, reason: str) -> None:
        super().__init__(reason)
        self.result = result
        self.reason = reason


@dataclass(frozen=True, slots=True)
class StoredItem:
    """One mission, fence or rally item as the vehicle keeps it."""

    command: int
    frame: int
    """MAV_FRAME_MISSION, or MAV_FRAME_GLOBAL / MAV_FRAME_GLOBAL_RELATIVE_ALT for every global item."""
    params: tuple[float, float, float, float]
    x: float
    """Latitude (degrees) of a global item; param5 as sent otherwise."""
    y: float
    """Longitude (degrees) of a global item; param6 as sent otherwise."""
    z: float
    """Altitude (m) in :attr:`frame`; param7 otherwise."""
    autocontinue: int = 1

    @property
    def is_global(self) -> bool:
        return bool(self.frame != MAV_FRAME_MISSION)

    @property
    def relative_alt(self) -> bool:
        return bool(self.frame == MAV_FRAME_GLOBAL_RELATIVE_ALT)

    @property
    def is_position(self) -> bool:
        """A navigation item with a place to fly to."""
        return self.is_global and self.command in POSITION_COMMANDS


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def decode_item(msg: Any, mission_type: int) -> StoredItem:
    """The item a MISSION_ITEM or MISSION_ITEM_INT carries for a plan of ``mission_type``; raises
    :class:`ItemRejected` with the MAV_MISSION_RESULT PX4 would answer."""
    is_int = msg.get_msgId() == mavlink2.MAVLINK_MSG_ID_MISSION_ITEM_INT
    frame, command = int(msg.frame), int(msg.command)
    params = (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4))
    if frame in _GLOBAL_FLOAT_FRAMES or (is_int and frame in _GLOBAL_INT_FRAMES):
        if command not in GLOBAL_COMMANDS:
            raise ItemRejected(MAV_MISSION_UNSUPPORTED, f"command {command} not supported with a position")
        if command in (MAV_CMD_NAV_ROI, MAV_CMD_DO_SET_ROI) and int(_or_zero(params[0])) not in _ROI_MODES_GLOBAL:
            raise ItemRejected(MAV_MISSION_INVALID_PARAM1, "ROI mode not supported")
        lat, lon = (msg.x / 1e7, msg.y / 1e7) if is_int else (float(msg.x), float(msg.y))
        if not (_finite(lat) and -90.0 <= lat <= 90.0):
            raise ItemRejected(MAV_MISSION_INVALID_PARAM5_X, "latitude out of range")
        if not (_finite(lon) and -180.0 <= lon <= 180.0):
            raise ItemRejected(MAV_MISSION_INVALID_PARAM6_Y, "longitude out of range")
        if abs(float(msg.z)) > MAX_ABS_ALTITUDE_M:  # NaN passes: "keep the altitude"
            raise ItemRejected(MAV_MISSION_INVALID_PARAM7, "altitude out of range")
        stored_frame = MAV_FRAME_GLOBAL_RELATIVE_ALT if frame in _RELATIVE_FRAMES else MAV_FRAME_GLOBAL
        item = StoredItem(command, stored_frame, params, lat, lon, float(msg.z), int(msg.autocontinue))
    elif frame == MAV_FRAME_MISSION:
        if command not in NON_POSITIONAL_COMMANDS:
            raise ItemRejected(MAV_MISSION_UNSUPPORTED, f"command {command} not supported without a position")
        if (
            command in (MAV_CMD_NAV_ROI, MAV_CMD_DO_SET_ROI)
            and int(_or_zero(params[0])) not in _ROI_MODES_NON_POSITIONAL
        ):
            raise ItemRejected(MAV_MISSION_INVALID_PARAM1, "ROI mode not supported")
        item = StoredItem(
            command, MAV_FRAME_MISSION, params, float(msg.x), float(msg.y), float(msg.z), int(msg.autocontinue)
        )
    else:
        raise ItemRejected(MAV_MISSION_UNSUPPORTED_FRAME, f"frame {frame} not supported")
    _check_plan(item, mission_type)
    return item


def _or_zero(x: float) -> float:
    return x if math.isfinite(x) else 0.0


def _check_plan(item: StoredItem, mission_type: int) -> None:
    if mission_type == MAV_MISSION_TYPE_MISSION and item.command in FENCE_COMMANDS | RALLY_COMMANDS:
        raise ItemRejected(MAV_MISSION_ERROR, "fence and rally items do not belong in a mission")
    if mission_type == MAV_MISSION_TYPE_FENCE:
        if item.command not in FENCE_COMMANDS:
            raise ItemRejected(MAV_MISSION_ERROR, "only fence items belong in a geofence")
        if item.command in FENCE_POLYGON_COMMANDS and vertex_count(item) < MIN_POLYGON_VERTICES:
            raise ItemRejected(MAV_MISSION_ERROR, "a fence polygon needs at least 3 vertices")
        if item.command in FENCE_CIRCLE_COMMANDS and not item.params[0] > 0:  # ours: PX4 takes any radius
            raise ItemRejected(MAV_MISSION_INVALID_PARAM1, "a fence circle needs a positive radius")
    if mission_type == MAV_MISSION_TYPE_RALLY and item.command not in RALLY_COMMANDS:
        raise ItemRejected(MAV_MISSION_ERROR, "only rally points belong in a rally plan")


def vertex_count(item: StoredItem) -> int:
    """A polygon vertex's param1, the number of vertices of its polygon (rounded as PX4 rounds it)."""
    return int(_or_zero(item.params[0]) + 0.5)


def encode_item(
    mav: mavlink2.MAVLink,
    item: StoredItem,
    seq: int,
    target: tuple[int, int],
    mission_type: int,
    *,
    current: bool,
    as_int: bool,
) -> Any:
    """MISSION_ITEM_INT (``as_int``) or MISSION_ITEM for ``item`` at ``seq``, as PX4 formats it for download."""
    p1, p2, p3, p4 = item.params
    if item.is_global:
        if as_int:
            frame = MAV_FRAME_GLOBAL_RELATIVE_ALT_INT if item.relative_alt else MAV_FRAME_GLOBAL_INT
        else:
            frame = item.frame
    else:
        frame = MAV_FRAME_MISSION
    x: float
    y: float
    if as_int:
        scale = 1e7 if item.is_global else 1.0
        x, y, encode = _int32(item.x * scale), _int32(item.y * scale), mav.mission_item_int_encode
    else:
        x, y, encode = item.x, item.y, mav.mission_item_encode
    return encode(
        *target, seq, frame, item.command, int(current), item.autocontinue, p1, p2, p3, p4, x, y, item.z, mission_type
    )


def _int32(x: float) -> int:
    if not math.isfinite(x):
        return 0
    return max(-(2**31), min(2**31 - 1, round(x)))


MISSION_TYPES = (MAV_MISSION_TYPE_MISSION, MAV_MISSION_TYPE_FENCE, MAV_MISSION_TYPE_RALLY)
"""The plan types the vehicle keeps, separately."""
