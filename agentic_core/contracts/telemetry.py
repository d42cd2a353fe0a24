"""TelemetrySample: the vehicle's state as its telemetry reports it, once per sample. It feeds perception (the
camera pose comes from it, not from simulator truth), the telemetry-based failsafes and ``telemetry.jsonl``.

>>> s = TelemetrySample(time_s=1.0, lat_deg=21.4, lon_deg=39.9, alt_m=10.0, north_m=1, east_m=2, down_m=-10)
>>> s.landed_state, s.armed
('unknown', False)
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

LandedState = Literal["unknown", "on_ground", "in_air", "takeoff", "landing"]


class TelemetrySample(BaseModel):
    """One sample of the vehicle's reported state (MAVLink GLOBAL_POSITION_INT, LOCAL_POSITION_NED, ATTITUDE,
    SYS_STATUS, HEARTBEAT, EXTENDED_SYS_STATE)."""

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


def telemetry_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`TelemetrySample`."""
    return TelemetrySample.model_json_schema()


__all__ = ["LandedState", "TelemetrySample", "telemetry_json_schema"]
