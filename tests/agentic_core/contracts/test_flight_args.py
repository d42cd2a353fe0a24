"""The flight actions' arguments are defined once: the mission DSL's models are the plain ones with ``${...}``
templates allowed, and the ``flight.*`` tools take the plain values (a template never reaches a vehicle)."""

from __future__ import annotations

import math
import typing

import jsonschema
import pytest
from pydantic import BaseModel, ValidationError

from agentic_core.contracts import flight_args, policy_graph
from flight.tools import flight_tools

PAIRS: dict[str, tuple[type[BaseModel], type[BaseModel], str]] = {
    "takeoff": (flight_args.TakeoffArgs, policy_graph.TakeoffArgs, "flight.takeoff"),
    "fly_to": (flight_args.FlyToArgs, policy_graph.FlyToArgs, "flight.fly_to"),
    "orbit": (flight_args.OrbitArgs, policy_graph.OrbitArgs, "flight.orbit"),
    "hover": (flight_args.HoverArgs, policy_graph.HoverArgs, "flight.hover"),
    "land": (flight_args.LandArgs, policy_graph.LandArgs, "flight.land"),
    "rtl": (flight_args.NoArgs, policy_graph.NoArgs, "flight.rtl"),
    "deploy_payload": (flight_args.DeployPayloadArgs, policy_graph.DeployPayloadArgs, "flight.deploy_payload"),
    "point": (flight_args.LatLon, policy_graph.LatLon, ""),
}
TEMPLATE = "${params.altitude_m + 10}"


def _generic_origin(model: type[BaseModel]) -> type[BaseModel]:
    """The model a class was derived from: its generic base's origin, or the class itself for a plain base."""
    for base in model.__mro__:
        origin = getattr(base, "__pydantic_generic_metadata__", {}).get("origin")
        if origin is not None:
            return typing.cast(type[BaseModel], origin)
    return next(b for b in model.__mro__ if b.__module__ == flight_args.__name__)


def _number_fields(model: type[BaseModel]) -> list[str]:
    def floats(annotation: object) -> bool:
        if annotation is float:
            return True
        if typing.get_origin(annotation) is typing.Annotated:
            return floats(typing.get_args(annotation)[0])
        return any(floats(a) for a in typing.get_args(annotation))

    return [name for name, field in model.model_fields.items() if floats(field.annotation)]


@pytest.fixture(scope="module")
def specs():
    async def never():
        raise AssertionError("no vehicle in this test")

    return {s.name: s for s in flight_tools(never)}


@pytest.mark.parametrize("action", sorted(PAIRS))
def test_the_dsl_model_is_derived_from_the_plain_ones_source(action: str) -> None:
    plain, templated, _ = PAIRS[action]
    assert plain is not templated
    assert _generic_origin(plain) is _generic_origin(templated)
    assert _generic_origin(plain).__module__ == flight_args.__name__
    assert list(plain.model_fields) == list(templated.model_fields)
    for name, field in plain.model_fields.items():
        assert templated.model_fields[name].default == field.default, name


@pytest.mark.parametrize("action", sorted(PAIRS))
def test_a_template_is_a_mission_value_never_a_plain_one(action: str) -> None:
    plain, templated, _ = PAIRS[action]
    numbers = _number_fields(plain)
    if action in ("rtl", "deploy_payload"):
        assert numbers == []
        return
    assert numbers
    base: dict[str, dict[str, object]] = {
        "takeoff": {},
        "fly_to": {"north_m": 1.0, "east_m": 2.0},
        "orbit": {"target_id": "P-1", "radius_m": 5.0},
        "hover": {"duration_s": 3.0},
        "land": {},
        "point": {"lat": 1.0, "lon": 2.0},
    }
    for name in numbers:
        args = base[action] | {name: TEMPLATE}
        if action == "fly_to" and name in ("lat", "lon"):
            args = {"lat": TEMPLATE, "lon": TEMPLATE}
        if action == "land" and name in ("lat", "lon"):
            args = {"lat": TEMPLATE, "lon": TEMPLATE}
        assert getattr(templated.model_validate(args), name) == TEMPLATE
        with pytest.raises(ValidationError) as caught:
            plain.model_validate(args)
        assert name in {str(e["loc"][0]) for e in caught.value.errors()}


@pytest.mark.parametrize("action", ["takeoff", "fly_to", "orbit", "hover", "land"])
def test_no_tool_schema_accepts_a_template_for_a_number(specs, action: str) -> None:
    plain, _, tool = PAIRS[action]
    schema = specs[tool].input_schema
    checked = 0
    for name in _number_fields(plain):
        assert name in schema["properties"]
        errors = list(jsonschema.Draft202012Validator(schema).iter_errors({name: TEMPLATE}))
        assert any(list(e.absolute_path) == [name] or name in e.message for e in errors), name
        checked += 1
    assert checked


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 91.0, -90.5, None, TEMPLATE])
def test_the_plain_point_refuses_what_is_no_latitude(bad: object) -> None:
    with pytest.raises(ValidationError):
        flight_args.LatLon.model_validate({"lat": bad, "lon": 39.8})


@pytest.mark.parametrize(
    ("model", "args", "reason"),
    [
        (flight_args.FlyToArgs, {"lat": 1.0, "lon": 2.0, "north_m": 3.0, "east_m": 4.0}, "exactly one destination"),
        (flight_args.FlyToArgs, {}, "exactly one destination"),
        (flight_args.FlyToArgs, {"lat": 1.0}, "lat and lon go together"),
        (flight_args.FlyToArgs, {"east_m": 1.0}, "north_m and east_m go together"),
        (flight_args.OrbitArgs, {"radius_m": 5.0}, "exactly one of center or target_id"),
        (flight_args.LandArgs, {"lat": 1.0, "lon": 2.0, "target_id": "P-1"}, "not both"),
        (flight_args.LandArgs, {"lon": 2.0}, "lat and lon go together"),
        (flight_args.TakeoffArgs, {"altitude_m": 10.0, "altitude": 20.0}, "Extra inputs are not permitted"),
    ],
)
def test_the_rules_hold_for_plain_and_templated_alike(
    model: type[BaseModel], args: dict[str, object], reason: str
) -> None:
    templated = getattr(policy_graph, model.__name__)
    for each in (model, templated):
        with pytest.raises(ValidationError) as caught:
            each.model_validate(args)
        assert reason in str(caught.value), each


def test_the_mission_stays_strict_where_the_plain_model_is_lax() -> None:
    """A quoted number in a mission file is an error there (as in its JSON Schema); a tool's caller is lax."""
    assert flight_args.HoverArgs.model_validate({"duration_s": "3"}).duration_s == 3.0
    with pytest.raises(ValidationError):
        policy_graph.HoverArgs.model_validate({"duration_s": "3"})
