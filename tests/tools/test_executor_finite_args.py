"""NaN and the infinities in a tool's arguments: refused by the executor as invalid arguments, one line naming the
field, before the tool (or its pydantic model) sees them; on the quick path for flat schemas and on jsonschema's."""

import math
from typing import Annotated, Any

import pytest
from pydantic import Field

from tools import ToolRegistry
from tools.arguments import non_finite

from .conftest import Counter, registered, stage
from .executor_fixtures import MakeExecutor, schema_tool

NON_FINITE = [math.nan, math.inf, -math.inf]
FiniteFloat = Annotated[float, Field(allow_inf_nan=False)]  # as the flight tools declare their numbers


def flight_like(registry: ToolRegistry, runs: Counter) -> None:
    @registered(registry, name="flight.fly_to")
    def fly_to(lat: FiniteFloat, lon: FiniteFloat, alt_m: FiniteFloat = 10.0) -> str:
        runs.hit()
        return "flying"


def goto_schema(registry: ToolRegistry, runs: Counter) -> None:
    point = {"type": "object", "properties": {"lat": {"type": "number"}, "lon": {"type": "number"}}}
    schema = {
        "type": "object",
        "properties": {"target": point, "path": {"type": "array", "items": point}, "speeds": {"type": "array"}},
    }
    schema_tool(registry, "flight.goto", lambda args: (runs.hit(), "ok")[1], input_schema=schema)


@pytest.mark.parametrize("bad", NON_FINITE, ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("field", ["lat", "lon", "alt_m"])
def test_a_non_finite_number_in_a_flat_call_is_an_invalid_argument(
    registry: ToolRegistry, make_executor: MakeExecutor, bad: float, field: str
) -> None:
    runs = Counter()
    flight_like(registry, runs)
    args = {"lat": 21.4, "lon": 39.8, "alt_m": 12.0, field: bad}
    result = make_executor(registry).call("flight.fly_to", args)
    assert result.status == "error" and runs.runs == 0
    assert result.error == f"invalid arguments: $.{field}: {bad} is not a finite number"
    assert stage(result, "validate_args").outcome == "failed"


@pytest.mark.parametrize("bad", NON_FINITE, ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize(
    ("args", "where"),
    [
        (lambda x: {"target": {"lat": x, "lon": 1.0}}, "$.target.lat"),
        (lambda x: {"path": [{"lat": 1.0, "lon": 2.0}, {"lat": 3.0, "lon": x}]}, "$.path[1].lon"),
        (lambda x: {"speeds": [1.0, [2.0, (x,)]]}, "$.speeds[1][1][0]"),
    ],
    ids=["object", "list-of-objects", "nested-lists-and-tuple"],
)
def test_a_nested_non_finite_number_is_named_by_its_path(
    registry: ToolRegistry, make_executor: MakeExecutor, bad: float, args: Any, where: str
) -> None:
    runs = Counter()
    goto_schema(registry, runs)
    result = make_executor(registry).call("flight.goto", args(bad))
    assert result.status == "error" and runs.runs == 0
    assert result.error == f"invalid arguments: {where}: {bad} is not a finite number"


def test_non_finite_numbers_join_the_other_errors_in_one_line(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    runs = Counter()
    flight_like(registry, runs)
    result = make_executor(registry).call("flight.fly_to", {"lat": math.nan, "lon": "east", "alt_m": -math.inf})
    assert result.error == (
        "invalid arguments: $.alt_m: -inf is not a finite number; $.lat: nan is not a finite number; "
        "$.lon: 'east' is not of type 'number'"
    )
    assert "\n" not in result.error and "pydantic" not in result.error and runs.runs == 0


def test_more_than_three_problems_are_counted(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "svc.any", lambda args: "ok")
    args = {name: math.nan for name in "abcde"}
    result = make_executor(registry).call("svc.any", args)
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("invalid arguments: $.a: nan is not a finite number;")
    assert result.error.endswith("(and 2 more)")


@pytest.mark.parametrize("value", [0.0, -0.0, 1e308, -1e308, 5e-324, 7])
def test_finite_numbers_still_pass(registry: ToolRegistry, make_executor: MakeExecutor, value: float) -> None:
    runs = Counter()
    flight_like(registry, runs)
    assert make_executor(registry).call("flight.fly_to", {"lat": value, "lon": 1.0}).ok
    goto_schema(registry, runs)
    assert make_executor(registry).call("flight.goto", {"target": {"lat": value}, "speeds": [value]}).ok
    assert runs.runs == 2


def test_the_text_nan_is_a_string_not_a_number(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="svc.say")
    def say(text: str) -> str:
        return text

    assert make_executor(registry).call("svc.say", {"text": "nan"}).output == "nan"


def test_a_self_containing_argument_is_walked_once() -> None:
    args: dict[str, Any] = {"x": math.inf}
    args["me"] = [args]
    assert non_finite(args) == [("$.x", math.inf)]
