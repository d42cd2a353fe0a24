"""The flight actions' arguments, defined once: plain values for the vehicle's tools, ``${...}`` ones for missions.

Each argument model is generic in ``V``, what a value may be besides a number. The classes here fix it to
``Never`` (a number and nothing else: what ``flight.*`` tools take); the mission DSL's classes in
:mod:`agentic_core.contracts.action_args` (and :mod:`~agentic_core.contracts.mission_values`, the positions) fix it
to ``Template``, so a mission may write ``"${params.alt}"``. Field names, bounds, defaults and cross-field rules
therefore cannot drift apart.

>>> from agentic_core.contracts.flight_args import FlyToArgs
>>> FlyToArgs(north_m=30, east_m=-5).north_m
30.0
>>> FlyToArgs(lat=21.4)
Traceback (most recent call last):
...
pydantic_core._pydantic_core.ValidationError: 1 validation error for FlyToArgs
  Value error, lat and lon go together [type=value_error, input_value={'lat': 21.4}, input_type=dict]
...
"""

from __future__ import annotations

from typing import Annotated, Generic, Never, TypeVar

from pydantic import BaseModel, ConfigDict, Field, model_validator

Number = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Latitude = Annotated[float, Field(ge=-90, le=90, allow_inf_nan=False)]
Longitude = Annotated[float, Field(ge=-180, le=180, allow_inf_nan=False)]

V = TypeVar("V")
"""What a value may be besides a number: ``Never`` (nothing) for a tool, a ``Template`` in a mission."""
P = TypeVar("P")
"""The point model a centre is given as (the plain or the templated :class:`LatLonOf`)."""


class Arguments(BaseModel):
    """Base of the argument models: an unknown argument is an error, not silently ignored."""

    model_config = ConfigDict(extra="forbid")


class LatLonOf(Arguments, Generic[V]):
    """A point on the earth."""

    lat: Latitude | V = Field(description="latitude, degrees (WGS-84)")
    lon: Longitude | V = Field(description="longitude, degrees (WGS-84)")


class TakeoffArgsOf(Arguments, Generic[V]):
    """Climb to a height above home."""

    altitude_m: Positive | V = Field(default=10.0, description="climb to this height above home")


class FlyToArgsOf(Arguments, Generic[V]):
    """Exactly one way of saying where: ``lat``/``lon``, local ``north_m``/``east_m``, or a world-model object."""

    lat: Latitude | V | None = None
    lon: Longitude | V | None = None
    north_m: Number | V | None = None
    east_m: Number | V | None = None
    target_id: str | None = Field(default=None, description="an object id of the world model, e.g. P-12")
    alt_m: NonNegative | V | None = Field(default=None, description="height above home; default: keep the current one")
    speed_mps: Positive | V | None = None

    @model_validator(mode="after")
    def _one_destination(self) -> FlyToArgsOf[V]:
        ways = [
            self.lat is not None or self.lon is not None,
            self.north_m is not None or self.east_m is not None,
            self.target_id is not None,
        ]
        if sum(ways) != 1:
            raise ValueError("give exactly one destination: lat and lon, north_m and east_m, or target_id")
        if ways[0] and (self.lat is None or self.lon is None):
            raise ValueError("lat and lon go together")
        if ways[1] and (self.north_m is None or self.east_m is None):
            raise ValueError("north_m and east_m go together")
        return self


class OrbitArgsOf(Arguments, Generic[V, P]):
    """Circle a point or a world-model object."""

    center: P | None = None
    target_id: str | None = None
    radius_m: Positive | V
    turns: Positive | V = 1.0
    alt_m: NonNegative | V | None = None

    @model_validator(mode="after")
    def _one_center(self) -> OrbitArgsOf[V, P]:
        if (self.center is None) == (self.target_id is None):
            raise ValueError("give exactly one of center or target_id")
        return self


class HoverArgsOf(Arguments, Generic[V]):
    """Hold position for a while."""

    duration_s: Positive | V


class LandArgsOf(Arguments, Generic[V]):
    """Land here (no arguments), at a position, or beside a world-model object (``offset_m`` away from it)."""

    lat: Latitude | V | None = None
    lon: Longitude | V | None = None
    target_id: str | None = None
    offset_m: NonNegative | V = Field(default=0.0, description="keep this distance from the target when landing")

    @model_validator(mode="after")
    def _one_place(self) -> LandArgsOf[V]:
        if (self.lat is None) != (self.lon is None):
            raise ValueError("lat and lon go together")
        if self.lat is not None and self.target_id is not None:
            raise ValueError("give lat and lon, or target_id, not both")
        return self


class NoArgs(Arguments):
    """An action without arguments (``rtl``)."""


class DeployPayloadArgs(Arguments):
    """Release the payload; ``payload`` names what is carried, for the record."""

    payload: str = "rescue_kit"


# The plain models: numbers only. No docstrings on purpose: a docstring would enter the tools' JSON Schemas.
class LatLon(LatLonOf[Never]):
    pass


class TakeoffArgs(TakeoffArgsOf[Never]):
    pass


class FlyToArgs(FlyToArgsOf[Never]):
    pass


class OrbitArgs(OrbitArgsOf[Never, LatLon]):
    pass


class HoverArgs(HoverArgsOf[Never]):
    pass


class LandArgs(LandArgsOf[Never]):
    pass


__all__ = [
    "Arguments",
    "DeployPayloadArgs",
    "FlyToArgs",
    "FlyToArgsOf",
    "HoverArgs",
    "HoverArgsOf",
    "LandArgs",
    "LandArgsOf",
    "LatLon",
    "LatLonOf",
    "Latitude",
    "Longitude",
    "NoArgs",
    "NonNegative",
    "Number",
    "OrbitArgs",
    "OrbitArgsOf",
    "P",
    "Positive",
    "TakeoffArgs",
    "TakeoffArgsOf",
    "V",
]
