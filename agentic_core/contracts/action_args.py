"""The arguments of each mission action: the flight actions' are :mod:`~agentic_core.contracts.flight_args`' models
with ``${...}`` templates allowed (no docstrings where the plain model has none: a docstring is part of the JSON
Schema); scene analysis and notification have their own."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from . import flight_args
from .mission_values import MAX_POINTS, Contract, LatLon, Positive, Template


class TakeoffArgs(flight_args.TakeoffArgsOf[Template], Contract):
    pass


class FlyToArgs(flight_args.FlyToArgsOf[Template], Contract):
    """Exactly one way of saying where: ``lat``/``lon``, local ``north_m``/``east_m``, or a world-model object."""


class SurveyArgs(Contract):
    polygon: Annotated[list[LatLon], Field(min_length=3, max_length=MAX_POINTS)] | Template = Field(
        description="the area, 3 to 10,000 points"
    )
    altitude_m: Positive
    spacing_m: Annotated[float, Field(ge=1, allow_inf_nan=False)] | Template = Field(
        default=20.0, description="distance between the lawnmower lines, at least 1 m"
    )
    speed_mps: Positive | None = None


class OrbitArgs(flight_args.OrbitArgsOf[Template, LatLon], Contract):
    pass


class HoverArgs(flight_args.HoverArgsOf[Template], Contract):
    pass


class LandArgs(flight_args.LandArgsOf[Template], Contract):
    """Land here (no arguments), at a position, or beside a world-model object (``offset_m`` away from it)."""


class NoArgs(flight_args.NoArgs, Contract):
    pass


class DeployPayloadArgs(flight_args.DeployPayloadArgs, Contract):
    pass


class AnalyzeSceneArgs(Contract):
    focus: str | None = Field(default=None, description="an object id, or a description of what to look at")
    min_confidence: Annotated[float, Field(ge=0, le=1)] | Template = 0.5


class NotifyArgs(Contract):
    channel: Literal["email", "webhook", "log"] = "email"
    to: list[str] | str | None = None
    subject: str
    body: str
    attach: list[str] = Field(default_factory=list, description="e.g. snapshot, position, world_model")


__all__ = [
    "AnalyzeSceneArgs",
    "DeployPayloadArgs",
    "FlyToArgs",
    "HoverArgs",
    "LandArgs",
    "NoArgs",
    "NotifyArgs",
    "OrbitArgs",
    "SurveyArgs",
    "TakeoffArgs",
]
