"""TelemetrySample: the vehicle's state as its telemetry reports it, once per sample. It feeds perception (the
camera pose comes from it, not from simulator truth), the telemetry-based failsafes and ``telemetry.jsonl``.

>>> s = TelemetrySample(time_s=1.0, lat_deg=21.4, lon_deg=39.9, alt_m=10.0, north_m=1, east_m=2, down_m=-10)
>>> s.landed_state, s.armed, s.wind_mps
('unknown', False, None)
"""

from __future__ import annotations

import math
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

LandedState = Literal["unknown", "on_ground", "in_air", "takeoff", "landing"]


class TelemetrySample(BaseModel):
    """One sample of the vehicle's reported state (MAVLink GLOBAL_POSITION_INT, LOCAL_POSITION_NED, ATTITUDE,
    SYS_STATUS, HEARTBEAT, EXTENDED_SYS_STATE, GPS_RAW_INT and, where the vehicle estimates wind, WIND_COV)."""

    model_config = ConfigDict(frozen=True)

    time_s: float = Field(description="the vehicle's clock, seconds since boot (simulated seconds in a simulation)")
    lat_deg: float
    lon_deg: float
    alt_m: float = Field(description="altitude above home")
    alt_msl_m: float | None = None
    north_m: float = Field(description="from home")
    east_m: float
    down_m: float
    vn_mps: float = 0.0
    ve_mps: float = 0.0
    vd_mps: float = 0.0
    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    yaw_deg: float = Field(default=0.0, description="heading, degrees clockwise from north")
    battery_pct: float | None = None
    mode: str = "unknown"
    armed: bool = False
    landed_state: LandedState = "unknown"
    gps_fix_type: int | None = Field(
        default=None, description="GPS_RAW_INT fix_type: 0-1 no fix, 2 2D, 3 3D and better; None: not reported"
    )
    gps_satellites: int | None = Field(default=None, description="GPS_RAW_INT satellites_visible")
    wind_north_mps: float | None = Field(
        default=None, description="the wind's estimate (WIND_COV wind_x: where the air moves towards, north)"
    )
    wind_east_mps: float | None = Field(default=None, description="WIND_COV wind_y (east)")

    @property
    def wind_mps(self) -> float | None:
        """The horizontal wind speed, when the vehicle reports a wind estimate."""
        if self.wind_north_mps is None or self.wind_east_mps is None:
            return None
        return math.hypot(self.wind_north_mps, self.wind_east_mps)


def telemetry_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`TelemetrySample`."""
    return TelemetrySample.model_json_schema()


__all__ = ["LandedState", "TelemetrySample", "telemetry_json_schema"]
