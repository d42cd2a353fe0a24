"""The flight envelope refuses a command outside the mission's limits however its place is written — lat/lon,
north/east from home, a world-model target, an orbit's circle, a landing place — and lets everything inside go."""

from __future__ import annotations

import math
from typing import Any

import pytest

from agentic_core.agent.envelope import Envelope
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.policy_graph import Limits

HOME = (21.4133, 39.8933)
CIRCLE = Limits.model_validate(
    {"geofence": {"center": {"lat": HOME[0], "lon": HOME[1]}, "radius_m": 200}, "max_altitude_m": 25}
)
CORNERS = [offset_position(*HOME, n, e) for n, e in ((-100, -100), (-100, 100), (100, 100), (100, -100))]
SQUARE = Limits.model_validate({"geofence": [{"lat": lat, "lon": lon} for lat, lon in CORNERS], "max_altitude_m": 60})


def at(north: float, east: float) -> dict[str, float]:
    lat, lon = offset_position(*HOME, north, east)
    return {"lat": lat, "lon": lon}


def envelope(limits: Limits, targets: dict[str, tuple[float, float]] | None = None) -> Envelope:
    known = targets or {}
    return Envelope(limits, home=lambda: HOME, targets=known.get)


@pytest.mark.parametrize("limits", [CIRCLE, SQUARE], ids=["circle", "polygon"])
@pytest.mark.parametrize(
    "args",
    [
        {"north_m": 215.0, "east_m": 0.0},  # local metres past the fence
        {"north_m": 0.0, "east_m": -250.0},
        at(215.0, 0.0),  # the same, in lat/lon
        {"target_id": "P-far"},  # a person the model wants to reach, outside
    ],
    ids=["north", "west", "latlon", "target"],
)
def test_a_destination_outside_is_refused_however_it_is_written(limits: Limits, args: dict[str, Any]) -> None:
    env = envelope(limits, {"P-far": tuple(at(230.0, 0.0).values())})  # type: ignore[dict-item]
    problems = env.check("flight.fly_to", {**args, "alt_m": 20.0})
    assert problems and "outside the geofence" in problems[0], problems


@pytest.mark.parametrize("limits", [CIRCLE, SQUARE], ids=["circle", "polygon"])
def test_inside_everything_goes(limits: Limits) -> None:
    env = envelope(limits, {"P-1": tuple(at(50.0, 20.0).values())})  # type: ignore[dict-item]
    assert env.check("flight.fly_to", {"north_m": 90.0, "east_m": -90.0, "alt_m": 20.0}) == []
    assert env.check("flight.fly_to", {**at(-90.0, 90.0), "alt_m": 3.0}) == []
    assert env.check("flight.fly_to", {"target_id": "P-1", "alt_m": 15.0}) == []
    assert env.check("flight.orbit", {"target_id": "P-1", "radius_m": 20.0, "alt_m": 20.0}) == []
    assert env.check("flight.land", {"target_id": "P-1", "offset_m": 5.0}) == []
    for quiet in ("flight.hover", "flight.hold", "flight.rtl", "flight.deploy_payload", "flight.status"):
        assert env.check(quiet, {"duration_s": 5}) == []


def test_an_orbit_whose_circle_crosses_the_fence_is_refused_though_its_centre_is_inside() -> None:
    env = envelope(CIRCLE)
    problems = env.check("flight.orbit", {"center": at(150.0, 0.0), "radius_m": 80.0, "alt_m": 20.0})
    assert problems == ["the orbit of radius 80 m leaves the geofence"]


def test_a_landing_place_outside_is_refused() -> None:
    env = envelope(SQUARE)
    assert env.check("flight.land", at(0.0, 140.0)) == ["the landing place is 40 m outside the geofence"]
    assert env.check("flight.land", {}) == []  # here: wherever the aircraft is, inside (the vehicle's fence says)


@pytest.mark.parametrize("limits", [CIRCLE, SQUARE], ids=["circle", "polygon"])
def test_a_landing_offset_that_may_take_it_past_the_fence_is_refused_though_the_target_is_inside(
    limits: Limits,
) -> None:
    env = envelope(limits, {"P-1": tuple(at(50.0, 20.0).values())})  # type: ignore[dict-item]
    assert env.check("flight.land", {"target_id": "P-1", "offset_m": 2000.0}) == [
        "landing 2000 m from the target may leave the geofence"
    ]  # the landing place lies offset_m from the target, on the side the aircraft comes from
    assert env.check("flight.land", {"target_id": "P-1", "offset_m": 8.0}) == []


def test_heights_the_ceiling_and_the_floor() -> None:
    env = envelope(CIRCLE)
    assert env.check("flight.takeoff", {"altitude_m": 30.0}) == [
        "altitude_m 30 m is above the ceiling of 25 m (limits.max_altitude_m)"
    ]
    assert env.check("flight.takeoff", {"altitude_m": 1.0}) == []  # take-off is exempt from the floor
    assert env.check("flight.fly_to", {"north_m": 0, "east_m": 0, "alt_m": 0.0}) == [
        "alt_m 0 m is below the floor of 2 m above home"
    ]
    assert env.check("flight.orbit", {"center": at(0, 0), "radius_m": 5, "alt_m": 26}) == [
        "alt_m 26 m is above the ceiling of 25 m (limits.max_altitude_m)"
    ]


def test_a_target_the_world_does_not_know_cannot_pass_unchecked() -> None:
    env = envelope(CIRCLE)
    assert env.check("flight.fly_to", {"target_id": "P-404"}) == [
        "target P-404 is not in the world model: its place cannot be checked"
    ]


def test_without_a_known_home_a_place_is_refused_not_waved_through() -> None:
    env = Envelope(CIRCLE, home=lambda: None)
    assert env.check("flight.fly_to", {**at(10, 10), "alt_m": 10}) == [
        "the vehicle's home is not known yet: a place cannot be checked"
    ]


def test_a_point_on_the_fence_is_inside_and_a_hair_outside_is_not() -> None:
    env = envelope(SQUARE)
    edge = env.check("flight.fly_to", {"north_m": 100.0, "east_m": 0.0, "alt_m": 10})
    assert edge == []
    past = env.check("flight.fly_to", {"north_m": 100.5, "east_m": 0.0, "alt_m": 10})
    assert past and "outside the geofence" in past[0]


@pytest.mark.parametrize("bad", [math.nan, math.inf, True, "215"])
def test_values_that_are_not_numbers_are_not_taken_for_places(bad: Any) -> None:
    """What is not a finite number names no place here (the tool's own schema refuses it before it flies)."""
    env = envelope(CIRCLE)
    assert env.check("flight.fly_to", {"north_m": bad, "east_m": 0.0}) == []


def test_no_limits_no_refusal() -> None:
    env = Envelope(None, home=lambda: HOME)
    assert env.check("flight.fly_to", {"north_m": 1e6, "east_m": 0.0, "alt_m": 500.0}) == []
