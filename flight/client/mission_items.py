"""Mission items as the agent writes them: :class:`MissionItem`, with constructors for the common ones.

Why: a mission is data the agent (or an LLM through the ``flight.upload_mission`` tool) builds, checks and sends;
a pydantic model validates it at that boundary and gives it a JSON Schema. An item is a MAVLink command with its
parameters: a *global* item (frames 0, 3, 5, 6, 10, 11) has ``lat``/``lon``/``alt``; any other has
``param5``..``param7``. On the wire it goes as MISSION_ITEM_INT (degrees×1e7).

Facts relied on (MAVLink ``common.xml`` through pymavlink's ``dialects/v20/common.py``; PX4 mission item handling
in ``mavlink_mission.cpp``):

* NAV_WAYPOINT 16: param1 hold time (s), param2 acceptance radius (m), param4 yaw (deg, NaN: unchanged).
  NAV_LOITER_UNLIM 17, NAV_LOITER_TIME 19 (param1 seconds), NAV_LAND 21, NAV_TAKEOFF 22 (param4 yaw), all with a
  position. NAV_RETURN_TO_LAUNCH 20 has none: PX4 takes it only in MAV_FRAME_MISSION 2.
* DO_CHANGE_SPEED 178: param1 speed type (1 ground), param2 m/s, param3 throttle (-1 unchanged); DO_GRIPPER 211:
  param1 instance, param2 action (RELEASE 0, GRAB 1); both in MAV_FRAME_MISSION.
* Fence items (plan type ``fence``): NAV_FENCE_POLYGON_VERTEX_INCLUSION / _EXCLUSION 5001/5002 with param1 the
  polygon's vertex count, NAV_FENCE_CIRCLE_INCLUSION / _EXCLUSION 5003/5004 with param1 the radius. Rally points
  (plan type ``rally``): NAV_RALLY_POINT 5100.
* MAV_FRAME_GLOBAL_RELATIVE_ALT_INT 6: altitude above home, the default here.

A take-off or landing given no position is sent at latitude/longitude 0, which the simulated vehicle reads as
"where the vehicle is" (a real PX4 wants the coordinates).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, Literal, Self

from pydantic import BaseModel, ConfigDict, Field, model_validator
from pymavlink.dialects.v20.common import (  # MAVLink's own constants, not restated here
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_DO_GRIPPER,
    MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION,
    MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION,
    MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_LOITER_TIME,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_CMD_NAV_RALLY_POINT,
    MAV_CMD_NAV_RETURN_TO_LAUNCH,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_NAV_WAYPOINT,
    MAV_FRAME_GLOBAL,
    MAV_FRAME_GLOBAL_INT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT,
    MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT,
    MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    MAV_FRAME_MISSION,
)

MissionType = Literal["mission", "fence", "rally"]
MISSION_TYPE_IDS: dict[MissionType, int] = {"mission": 0, "fence": 1, "rally": 2}
"""MAV_MISSION_TYPE of each plan type."""

GLOBAL_FRAMES = frozenset(
    {
        MAV_FRAME_GLOBAL,
        MAV_FRAME_GLOBAL_RELATIVE_ALT,
        MAV_FRAME_GLOBAL_INT,
        MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT,
        MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
GRIPPER_RELEASE = 0
GROUND_SPEED = 1
NAN = math.nan


class MissionItem(BaseModel):
    """One item of a mission, geofence or rally plan."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    command: int = Field(ge=0, le=65535, description="MAV_CMD, e.g. 16 NAV_WAYPOINT, 22 NAV_TAKEOFF, 21 NAV_LAND")
    frame: int = Field(
        default=MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        ge=0,
        le=255,
        description="MAV_FRAME: 6 global, altitude above home (default); 5 above mean sea level; 2 no position",
    )
    lat: float | None = Field(default=None, ge=-90, le=90, description="degrees (WGS-84); global frames only")
    lon: float | None = Field(default=None, ge=-180, le=180, description="degrees (WGS-84); global frames only")
    alt: float = Field(default=0.0, description="metres, in the frame (above home for frame 6); global frames only")
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    param5: float = Field(default=0.0, description="x, for items without a position (sent as an integer)")
    param6: float = Field(default=0.0, description="y, for items without a position (sent as an integer)")
    param7: float = Field(default=0.0, description="z, for items without a position")
    autocontinue: bool = Field(default=True, description="go on to the next item once this one is done")

    @model_validator(mode="after")
    def _fields_fit_the_frame(self) -> Self:
        if self.is_global:
            if (self.lat is None) != (self.lon is None):
                raise ValueError("lat and lon go together")
        elif self.lat is not None or self.lon is not None:
            raise ValueError(f"frame {self.frame} has no position: use param5/param6/param7, not lat/lon")
        return self

    @property
    def is_global(self) -> bool:
        return self.frame in GLOBAL_FRAMES

    # -- constructors -----------------------------------------------------------------------------------------

    @classmethod
    def waypoint(
        cls, lat: float, lon: float, alt: float, *, hold_s: float = 0.0, acceptance_m: float = 0.0, yaw_deg: float = NAN
    ) -> MissionItem:
        """Fly to ``lat, lon`` at ``alt`` m above home; hold there ``hold_s``; reached within ``acceptance_m`` (0:
        the vehicle's default)."""
        return cls(
            command=MAV_CMD_NAV_WAYPOINT, lat=lat, lon=lon, alt=alt, param1=hold_s, param2=acceptance_m, param4=yaw_deg
        )

    @classmethod
    def takeoff(
        cls, alt: float, *, lat: float | None = None, lon: float | None = None, yaw_deg: float = NAN
    ) -> MissionItem:
        """Take off to ``alt`` m above home (here, unless a position is given); a waypoint if already flying."""
        return cls(
            command=MAV_CMD_NAV_TAKEOFF,
            lat=0.0 if lat is None else lat,
            lon=0.0 if lon is None else lon,
            alt=alt,
            param4=yaw_deg,
        )

    @classmethod
    def land(cls, lat: float | None = None, lon: float | None = None, *, yaw_deg: float = NAN) -> MissionItem:
        """Land at ``lat, lon`` (flown to first), or where the vehicle is."""
        return cls(
            command=MAV_CMD_NAV_LAND, lat=0.0 if lat is None else lat, lon=0.0 if lon is None else lon, param4=yaw_deg
        )

    @classmethod
    def rtl(cls) -> MissionItem:
        """Return to launch (and land there)."""
        return cls(command=MAV_CMD_NAV_RETURN_TO_LAUNCH, frame=MAV_FRAME_MISSION)

    @classmethod
    def loiter(cls, lat: float, lon: float, alt: float, *, seconds: float | None = None) -> MissionItem:
        """Hover at ``lat, lon, alt`` for ``seconds`` (None: until told otherwise)."""
        if seconds is None:
            return cls(command=MAV_CMD_NAV_LOITER_UNLIM, lat=lat, lon=lon, alt=alt, param4=NAN)
        return cls(command=MAV_CMD_NAV_LOITER_TIME, lat=lat, lon=lon, alt=alt, param1=seconds)

    @classmethod
    def change_speed(cls, speed_mps: float) -> MissionItem:
        """Fly the following legs at ``speed_mps`` over the ground."""
        return cls(
            command=MAV_CMD_DO_CHANGE_SPEED, frame=MAV_FRAME_MISSION, param1=GROUND_SPEED, param2=speed_mps, param3=-1.0
        )

    @classmethod
    def release_payload(cls, instance: int = 1) -> MissionItem:
        """Open the gripper (DO_GRIPPER RELEASE)."""
        return cls(command=MAV_CMD_DO_GRIPPER, frame=MAV_FRAME_MISSION, param1=instance, param2=GRIPPER_RELEASE)

    @classmethod
    def fence_circle(cls, lat: float, lon: float, radius_m: float, *, inclusion: bool = True) -> MissionItem:
        """A circular fence area (plan type ``fence``): stay inside it (``inclusion``) or out of it."""
        command = MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION if inclusion else MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION
        return cls(command=command, lat=lat, lon=lon, param1=radius_m)

    @classmethod
    def fence_polygon(cls, vertices: Sequence[tuple[float, float]], *, inclusion: bool = True) -> list[MissionItem]:
        """A polygonal fence area (plan type ``fence``) from (lat, lon) vertices: one item per vertex."""
        command = (
            MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION if inclusion else MAV_CMD_NAV_FENCE_POLYGON_VERTEX_EXCLUSION
        )
        return [cls(command=command, lat=lat, lon=lon, param1=len(vertices)) for lat, lon in vertices]

    @classmethod
    def rally_point(cls, lat: float, lon: float, alt: float) -> MissionItem:
        """A safe point to return to (plan type ``rally``)."""
        return cls(command=MAV_CMD_NAV_RALLY_POINT, lat=lat, lon=lon, alt=alt)

    # -- the wire ---------------------------------------------------------------------------------------------

    def int_fields(self) -> tuple[int, int, float, float, float, float, int, int, float]:
        """(frame, command, param1..param4, x, y, z) of MISSION_ITEM_INT."""
        if self.is_global:
            x, y, z = _degE7(self.lat or 0.0), _degE7(self.lon or 0.0), self.alt
        else:
            x, y, z = _int32(self.param5), _int32(self.param6), self.param7
        return self.frame, self.command, self.param1, self.param2, self.param3, self.param4, x, y, z

    @classmethod
    def from_message(cls, msg: Any) -> MissionItem:
        """The item a MISSION_ITEM_INT (or legacy MISSION_ITEM) carries."""
        frame = int(msg.frame)
        is_int = msg.get_type() == "MISSION_ITEM_INT"
        common = {
            "command": int(msg.command),
            "frame": frame,
            "param1": float(msg.param1),
            "param2": float(msg.param2),
            "param3": float(msg.param3),
            "param4": float(msg.param4),
            "autocontinue": bool(msg.autocontinue),
        }
        if frame in GLOBAL_FRAMES:
            scale = 1e-7 if is_int else 1.0
            return cls(**common, lat=msg.x * scale, lon=msg.y * scale, alt=float(msg.z))
        return cls(**common, param5=float(msg.x), param6=float(msg.y), param7=float(msg.z))


def _degE7(deg: float) -> int:
    return round(deg * 1e7)


def _int32(x: float) -> int:
    return max(-(2**31), min(2**31 - 1, round(x))) if math.isfinite(x) else 0
