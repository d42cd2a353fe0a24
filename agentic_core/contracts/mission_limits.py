"""A mission's safety limits (:class:`Limits`): the geofence, ceiling, battery, wind, flight time and link loss,
and what each failsafe on telemetry does."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from .mission_values import MAX_POINTS, Circle, Contract, LatLon

FailsafeAction = Literal["rtl", "land", "hold"]
FailsafeKind = Literal["battery", "link", "wind", "gps", "flight_time"]
"""The failsafes evaluated on telemetry (:mod:`agentic_core.agent.failsafes`)."""
GPS_LANDS: dict[FailsafeKind, FailsafeAction] = {"gps": "land"}


class Limits(Contract):
    """Safety limits every step is checked against at load time and by the flight envelope when it flies."""

    geofence: Annotated[list[LatLon], Field(min_length=3, max_length=MAX_POINTS)] | Circle | None = Field(
        default=None, description="a polygon of 3 to 10,000 points, or a circle"
    )
    max_altitude_m: float | None = Field(default=None, gt=0, description="above the home position")
    min_battery_pct: float | None = Field(default=None, ge=0, le=100)
    max_wind_mps: float | None = Field(default=None, gt=0)
    max_flight_time_s: float | None = Field(
        default=None, gt=0, description="the mission's time limit: seconds of the vehicle's clock since take-off"
    )
    link_loss_s: float = Field(
        default=10.0, gt=0, description="no telemetry for this long in the air is a lost link (PX4's COM_DL_LOSS_T)"
    )
    failsafe_action: FailsafeAction = Field(
        default="rtl", description="what a failsafe on telemetry does: return to launch, land or hold where it is"
    )
    failsafe_actions: dict[FailsafeKind, FailsafeAction] = Field(
        default_factory=lambda: dict(GPS_LANDS),
        description="a failsafe's own action, over failsafe_action (GPS loss lands unless told otherwise: a "
        "return needs a position)",
    )


__all__ = ["GPS_LANDS", "FailsafeAction", "FailsafeKind", "Limits"]
