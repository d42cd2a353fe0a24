"""``@tool``: schemas from type hints and docstrings (Google, NumPy, Sphinx), validation through the executor,
ToolContext injection, positional-only and async functions, output conversion and definition errors."""

import asyncio
import threading
from collections.abc import Callable
from typing import Annotated, Any, Literal

import pytest
from pydantic import Field

from tools import ToolContext, ToolDefinitionError, ToolExecutor, ToolRegistry, tool, tool_spec
from tools.function import parse_docstring

from .conftest import Forecast, Point, stage, stage_names


def props(fn: Callable[..., Any]) -> dict[str, Any]:
    return dict(tool_spec(fn).input_schema["properties"])


def run(
    make_executor: Callable[..., ToolExecutor], fn: Callable[..., Any], args: dict[str, Any] | None, **kw: Any
) -> Any:
    registry = ToolRegistry()
    registry.register(fn)
    return make_executor(registry).call(tool_spec(fn).name, args, **kw)


# docstrings -------------------------------------------------------------------------------------------------------
def test_google_docstring() -> None:
    @tool(name="weather.wind")
    def wind(lat: float, lon: float, units: str = "mps") -> float:
        """Wind speed at a place.

        More detail that is not part of the summary.

        Args:
            lat (float): latitude in degrees,
                north positive
            lon: longitude in degrees
            units: ``mps`` or ``kt``

        Returns:
            the wind speed
        """
        return 4.2

    spec = tool_spec(wind)
    assert spec.description == "Wind speed at a place."
    assert {k: v.get("description") for k, v in props(wind).items()} == {
        "lat": "latitude in degrees, north positive",
        "lon": "longitude in degrees",
        "units": "``mps`` or ``kt``",
    }


def test_numpy_docstring() -> None:
    @tool(name="weather.wind")
    def wind(lat: float, lon: float) -> float:
        """Wind speed at a place.

        Parameters
        ----------
        lat : float
            latitude in degrees
        lon : float
            longitude in degrees

        Returns
        -------
        float
            the wind speed
        """
        return 4.2

    assert tool_spec(wind).description == "Wind speed at a place."
    assert props(wind)["lat"]["description"] == "latitude in degrees"
    assert props(wind)["lon"]["description"] == "longitude in degrees"


def test_numpy_parameters_parse_without_their_types() -> None:
    """The NumPy ``name : type`` line names the parameter; its description is the indented text below."""
    _, params = parse_docstring("Summary.\n\nParameters\n----------\nalt : float\n    height in metres\n")
    assert params == {"alt": "height in metres"}


def test_sphinx_docstring() -> None:
    @tool(name="weather.wind")
    def wind(lat: float, lon: float) -> float:
        """Wind speed at a place.

        :param lat: latitude in degrees
        :param float lon: longitude in degrees
        :type lat: float
        :returns: the wind speed
        """
        return 4.2

    assert tool_spec(wind).description == "Wind speed at a place."
    assert props(wind)["lat"]["description"] == "latitude in degrees"
    assert props(wind)["lon"]["description"] == "longitude in degrees"


def test_summary_is_the_first_paragraph_on_one_line_and_description_overrides() -> None:
    assert parse_docstring("Fly to a point\nand hover.\n\nDetails.") == ("Fly to a point and hover.", {})
    assert parse_docstring(None) == ("", {})

    @tool(name="flight.hover", description="Hold position.")
    def hover(duration_s: float) -> None:
        """Ignored summary."""

    assert tool_spec(hover).description == "Hold position."


def test_default_name_is_module_and_function() -> None:
    @tool
    def ping() -> str:
        return "pong"

    assert tool_spec(ping).name == "test_function_schema.ping"


# parameter types ---------------------------------------------------------------------------------------------------
def test_defaults_optional_and_literal() -> None:
    @tool(name="camera.shoot")
    def shoot(count: int, zoom: float = 1.0, note: str | None = None, mode: Literal["photo", "video"] = "photo") -> int:
        return count

    spec = tool_spec(shoot)
    assert spec.input_schema["required"] == ["count"]
    assert spec.input_schema["additionalProperties"] is False
    p = props(shoot)
    assert p["count"]["type"] == "integer"
    assert p["zoom"] == {"default": 1.0, "title": "Zoom", "type": "number"}
    assert p["note"]["default"] is None
    assert {"type": "null"} in p["note"]["anyOf"] and {"type": "string"} in p["note"]["anyOf"]
    assert p["mode"]["enum"] == ["photo", "video"] and p["mode"]["default"] == "photo"


def test_optional_and_defaults_at_call_time(make_executor: Callable[..., ToolExecutor]) -> None:
    seen: list[tuple[Any, ...]] = []

    @tool(name="camera.shoot")
    def shoot(count: int, zoom: float = 1.0, note: str | None = None) -> int:
        seen.append((count, zoom, note))
        return count

    registry = ToolRegistry()
    registry.register(shoot)
    executor = make_executor(registry)
    assert executor.call("camera.shoot", {"count": 2}).ok
    assert executor.call("camera.shoot", {"count": 3, "note": None, "zoom": 2}).ok
    assert executor.call("camera.shoot", {"count": 4, "note": "sunset"}).ok
    assert seen == [(2, 1.0, None), (3, 2.0, None), (4, 1.0, "sunset")]
    refused = executor.call("camera.shoot", {"count": 1, "flash": True})
    assert refused.status == "error" and "Additional properties are not allowed ('flash' was unexpected)" in (
        refused.error or ""
    )


def test_pydantic_model_parameter(make_executor: Callable[..., ToolExecutor]) -> None:
    received: list[Any] = []

    @tool(name="flight.goto")
    def goto(target: Point, alt_m: float = 30) -> bool:
        received.append(target)
        return True

    schema = tool_spec(goto).input_schema
    assert schema["properties"]["target"] == {"$ref": "#/$defs/Point"}
    assert schema["$defs"]["Point"]["properties"]["lat"]["maximum"] == 90
    result = run(make_executor, goto, {"target": {"lat": 21.4, "lon": 39.8}})
    assert result.ok and result.output is True
    assert received == [Point(lat=21.4, lon=39.8)]  # the function gets the model, not a dict
    bad = run(make_executor, goto, {"target": {"lat": 91, "lon": 39.8}})
    assert bad.status == "error" and bad.error.startswith("invalid arguments: $.target.lat: 91 is greater than")


def test_annotated_field_constraints_are_enforced(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="flight.climb")
    def climb(alt_m: Annotated[float, Field(ge=0, le=120)], rate: int = Field(2, ge=1, le=5)) -> float:
        return alt_m

    p = props(climb)
    assert (p["alt_m"]["minimum"], p["alt_m"]["maximum"]) == (0, 120)
    assert (p["rate"]["minimum"], p["rate"]["maximum"], p["rate"]["default"]) == (1, 5, 2)
    assert run(make_executor, climb, {"alt_m": 50}).output == 50
    high = run(make_executor, climb, {"alt_m": 121})
    assert high.status == "error" and high.error == "invalid arguments: $.alt_m: 121 is greater than the maximum of 120"
    assert stage_names(high) == ["lookup:passed", "validate_args:failed", "audit:passed"]
    slow = run(make_executor, climb, {"alt_m": 1, "rate": 0})
    assert slow.error == "invalid arguments: $.rate: 0 is less than the minimum of 1"


def test_annotated_field_description_reaches_the_schema() -> None:
    @tool(name="flight.climb")
    def climb(alt_m: Annotated[float, Field(ge=0, description="target altitude in metres")]) -> float:
        """Climb."""
        return alt_m

    assert props(climb)["alt_m"]["description"] == "target altitude in metres"
    assert props(climb)["alt_m"]["minimum"] == 0


# ToolContext -------------------------------------------------------------------------------------------------------
def test_tool_context_is_injected_and_not_in_the_schema(make_executor: Callable[..., ToolExecutor]) -> None:
    from tools import Caller

    contexts: list[ToolContext] = []

    @tool(name="svc.whoami")
    def whoami(context: ToolContext, greeting: str = "hi") -> str:
        contexts.append(context)
        return f"{greeting} {context.caller.id}"

    assert "context" not in props(whoami) and "context" not in tool_spec(whoami).input_schema.get("required", [])
    result = run(make_executor, whoami, {}, caller=Caller(id="drone-7"), call_id="call-1", timeout_s=5)
    assert result.ok and result.output == "hi drone-7"
    [context] = contexts
    assert (context.call_id, context.tool, context.caller.id, context.attempt) == ("call-1", "svc.whoami", "drone-7", 1)
    assert context.deadline is not None


@pytest.mark.filterwarnings("ignore:The 'initial' parameter is deprecated:DeprecationWarning")
def test_tool_context_counts_attempts(make_executor: Callable[..., ToolExecutor]) -> None:
    from tools import RetrySpec, TransientToolError

    attempts: list[int] = []

    @tool(name="svc.flaky", retry=RetrySpec(attempts=3, initial_s=0, jitter_s=0))
    def flaky(ctx: ToolContext) -> int:
        attempts.append(ctx.attempt)
        if ctx.attempt < 3:
            raise TransientToolError("busy")
        return ctx.attempt

    result = run(make_executor, flaky, {})
    assert result.ok and result.output == 3 and result.attempts == 3 and attempts == [1, 2, 3]


def test_positional_only_parameters(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="math.sub")
    def sub(a: int, b: int, /, scale: int = 1) -> int:
        return (a - b) * scale

    assert set(props(sub)) == {"a", "b", "scale"}
    assert run(make_executor, sub, {"b": 2, "a": 10}).output == 8
    assert run(make_executor, sub, {"a": 10, "b": 2, "scale": 3}).output == 24


def test_positional_only_context_parameter(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="math.inc")
    def inc(ctx: ToolContext, a: int, /) -> int:
        return a + ctx.attempt

    assert set(props(inc)) == {"a"}
    result = run(make_executor, inc, {"a": 1})
    assert result.ok, result.error
    assert result.output == 2


# definition errors -------------------------------------------------------------------------------------------------
def test_missing_type_hint_is_a_definition_error() -> None:
    def bad(lat, lon: float) -> float:
        return lon

    with pytest.raises(ToolDefinitionError, match="parameter 'lat' needs a type hint"):
        tool(name="svc.bad")(bad)


@pytest.mark.parametrize("star", ["args", "kwargs"])
def test_star_parameters_are_definition_errors(star: str) -> None:
    def var_positional(*args: int) -> int:
        return 0

    def var_keyword(**kwargs: int) -> int:
        return 0

    fn = var_positional if star == "args" else var_keyword
    with pytest.raises(ToolDefinitionError, match=rf"\*{star} cannot be described by a schema"):
        tool(name="svc.bad")(fn)


def test_unresolvable_and_unschemable_hints_are_definition_errors() -> None:
    class Opaque:
        pass

    def unresolvable(x: "NoSuchType") -> int:  # type: ignore[name-defined]  # noqa: F821
        return 0

    def opaque_param(x: Opaque) -> int:
        return 0

    def opaque_return(x: int) -> Opaque:
        return Opaque()

    with pytest.raises(ToolDefinitionError, match="cannot resolve the type hints of unresolvable"):
        tool(name="svc.bad")(unresolvable)
    with pytest.raises(ToolDefinitionError, match="its parameters have no JSON Schema"):
        tool(name="svc.bad")(opaque_param)
    with pytest.raises(ToolDefinitionError, match="its return type has no JSON Schema"):
        tool(name="svc.bad")(opaque_return)


def test_tool_spec_of_an_undecorated_function() -> None:
    def plain() -> None:
        pass

    with pytest.raises(ToolDefinitionError, match="'plain' is not a tool"):
        tool_spec(plain)


# async functions ---------------------------------------------------------------------------------------------------
def test_async_function_tool(make_executor: Callable[..., ToolExecutor]) -> None:
    loops: list[str] = []

    @tool(name="svc.async_add")
    async def add(a: int, b: int) -> int:
        await asyncio.sleep(0)
        loops.append(threading.current_thread().name)
        return a + b

    spec = tool_spec(add)
    assert spec.is_async and spec.output_schema == {"type": "integer"}
    result = run(make_executor, add, {"a": 2, "b": 5})
    assert result.ok and result.output == 7 and result.attempts == 1
    assert loops == ["tool-async-loop"]  # called from sync code: run on the executor's background loop


# outputs -----------------------------------------------------------------------------------------------------------
def test_pydantic_output_becomes_json(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="weather.forecast")
    def forecast(lat: float) -> Forecast:
        return Forecast(wind_mps=4.5, summary="calm")

    spec = tool_spec(forecast)
    assert spec.output_schema is not None and spec.output_schema["required"] == ["wind_mps", "summary"]
    result = run(make_executor, forecast, {"lat": 1.0})
    assert result.ok and result.output == {"wind_mps": 4.5, "summary": "calm"}


def test_output_that_matches_after_conversion(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="weather.forecast")
    def forecast() -> Forecast:
        return {"wind_mps": 3, "summary": "breezy"}  # type: ignore[return-value]

    result = run(make_executor, forecast, {})
    assert result.ok and result.output == {"wind_mps": 3.0, "summary": "breezy"}


def test_output_mismatch_is_an_error_at_validate_output(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="weather.forecast")
    def forecast() -> Forecast:
        return {"wind_mps": "strong", "summary": "gusty"}  # type: ignore[return-value]

    @tool(name="math.count")
    def count() -> int:
        return "many"  # type: ignore[return-value]

    bad_model = run(make_executor, forecast, {})
    assert bad_model.status == "error" and bad_model.output is None
    assert bad_model.error is not None
    assert bad_model.error.startswith("the tool's output does not match its schema: $.wind_mps:")
    assert stage_names(bad_model)[-3:] == ["invoke:passed", "validate_output:failed", "audit:passed"]
    assert stage(bad_model, "validate_output").detail == bad_model.error
    bad_int = run(make_executor, count, {})
    assert bad_int.status == "error" and bad_int.error is not None and "does not match its schema: $:" in bad_int.error


def test_a_function_without_return_hint_has_no_output_schema(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="svc.anything")
    def anything(x: int):
        return {"x": [x, "y"]}

    assert tool_spec(anything).output_schema is None
    assert run(make_executor, anything, {"x": 1}).output == {"x": [1, "y"]}


def test_no_parameters(make_executor: Callable[..., ToolExecutor]) -> None:
    @tool(name="flight.rtl")
    def rtl() -> str:
        return "returning"

    assert tool_spec(rtl).input_schema == {"additionalProperties": False, "properties": {}, "type": "object"}
    assert run(make_executor, rtl, {}).output == "returning"
    assert run(make_executor, rtl, None).output == "returning"
