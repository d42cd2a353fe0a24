"""What a mission may write where a value is expected, and the base of every mission model: the plain values of
:mod:`~agentic_core.contracts.flight_args` or a ``${...}`` template evaluated when the step runs; :class:`Contract`,
strict and closed; the positions a mission names (:class:`LatLon`, :class:`Circle`).

>>> from agentic_core.contracts.mission_values import LatLon
>>> LatLon.model_validate({"lat": 21.42, "lon": "${params.lon}"}).lon
'${params.lon}'
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field, StringConstraints

from . import flight_args

TEMPLATE_PATTERN = r"^\$\{.+\}$"
Template = Annotated[str, StringConstraints(pattern=TEMPLATE_PATTERN)]
"""A value computed when the step runs: ``"${params.altitude_m + 10}"``."""

MAX_POINTS = 10_000
"""The most points a mission's polygon (a geofence, a survey or swarm area) may have: finer than any area a
vehicle's fence holds, and a list far longer would cost seconds and gigabytes to check (850,000 points: 80 s)."""

Number = flight_args.Number | Template
Positive = flight_args.Positive | Template
NonNegative = flight_args.NonNegative | Template
Latitude = flight_args.Latitude | Template
Longitude = flight_args.Longitude | Template


class Contract(BaseModel):
    """Base of every mission model: unknown fields are errors, not silently ignored."""

    model_config = ConfigDict(extra="forbid", strict=True)  # "30" is not a number here: as in the JSON Schema


# The flight actions' arguments are flight_args' models with ${...} templates allowed; no docstrings where the
# plain model has none (a docstring is part of the JSON Schema).
class LatLon(flight_args.LatLonOf[Template], Contract):
    pass


class Circle(Contract):
    center: LatLon
    radius_m: float = Field(gt=0)


__all__ = [
    "MAX_POINTS",
    "TEMPLATE_PATTERN",
    "Circle",
    "Contract",
    "LatLon",
    "Latitude",
    "Longitude",
    "NonNegative",
    "Number",
    "Positive",
    "Template",
]
