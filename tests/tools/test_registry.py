"""The tool registry: registration paths, definition errors, listeners, describe, the catalogue and its OpenAI and
MCP exports."""

import re
import threading
import types
from typing import Any

import pytest
from pydantic import BaseModel

from tools import (
    BreakerPolicy,
    ToolDefinitionError,
    ToolDescription,
    ToolExecutor,
    ToolRegistry,
    ToolSpec,
    UnknownToolError,
    openai_name,
    tool,
)

from .conftest import FakeClock, registered


class Reading(BaseModel):
    value: float
    unit: str


def echo_spec(name: str, **options: Any) -> ToolSpec:
    return ToolSpec.from_schema(name, lambda args: args, {"type": "object"}, **options)


# registration ---------------------------------------------------------------------------------------------------
def test_register_a_decorated_function() -> None:
    @tool(name="math.add")
    def add(a: int, b: int) -> int:
        """Add two numbers."""
        return a + b

    registry = ToolRegistry()
    spec = registry.register(add)
    assert spec.name == "math.add" and spec.source == "python"
    assert "math.add" in registry and len(registry) == 1
    assert registry.get("math.add") is spec
    assert [s.name for s in registry] == ["math.add"]
    assert add(2, 3) == 5  # still a plain function


def test_registry_tool_decorator_with_and_without_options() -> None:
    registry = ToolRegistry()

    @registry.tool(name="math.mul", scopes=["math:use"])
    def mul(a: int, b: int) -> int:
        return a * b

    @registry.tool
    def negate(a: int) -> int:
        return -a

    assert registry.names() == ["math.mul", "test_registry.negate"]  # a bare decorator names it module.function
    assert registry.get("math.mul").scopes == ("math:use",)


def test_registry_tool_reuses_the_spec_of_a_decorated_function() -> None:
    @tool(name="math.sub", idempotent=True, cache_ttl_s=5)
    def sub(a: int, b: int) -> int:
        return a - b

    registry = ToolRegistry()
    registry.tool(sub)
    assert registry.get("math.sub").cache_ttl_s == 5


def test_register_a_schema_tool() -> None:
    registry = ToolRegistry()
    spec = registry.register(
        ToolSpec.from_schema(
            "db.count",
            lambda args: len(args["rows"]),
            {"type": "object", "properties": {"rows": {"type": "array"}}, "required": ["rows"]},
            description="Count rows.",
            output_schema={"type": "integer"},
        )
    )
    assert spec.source == "schema" and spec.description == "Count rows."
    assert registry.get("db.count").output_schema == {"type": "integer"}


def test_a_taken_name_is_an_error_unless_replace() -> None:
    registry = ToolRegistry()
    registry.register(echo_spec("svc.echo", description="first"))
    with pytest.raises(ToolDefinitionError, match=r"'svc.echo' is already registered \(pass replace=True"):
        registry.register(echo_spec("svc.echo", description="second"))
    assert registry.get("svc.echo").description == "first"
    registry.register(echo_spec("svc.echo", description="second"), replace=True)
    assert registry.get("svc.echo").description == "second" and len(registry) == 1


def test_a_replaced_tool_gets_fresh_guards(clock: FakeClock) -> None:
    registry = ToolRegistry(clock=clock)
    registry.register(echo_spec("svc.echo", breaker=BreakerPolicy(failure_threshold=1)))
    entry = registry.entry("svc.echo")
    assert entry is not None
    entry.breaker.failure()
    assert registry.describe("svc.echo").breaker == "open"
    registry.register(echo_spec("svc.echo", breaker=BreakerPolicy(failure_threshold=1)), replace=True)
    assert registry.describe("svc.echo").breaker == "closed"


def test_unregister() -> None:
    registry = ToolRegistry()
    registry.register(echo_spec("weather.get_forecast"))
    registry.register(echo_spec("weather.get_alerts"))
    removed = registry.unregister("weather.get_forecast")
    assert removed.name == "weather.get_forecast"
    assert registry.names() == ["weather.get_alerts"]
    with pytest.raises(UnknownToolError) as raised:
        registry.unregister("weather.get_alert")
    assert raised.value.closest == ["weather.get_alerts"]
    assert str(raised.value) == "unknown tool 'weather.get_alert'; did you mean 'weather.get_alerts'?"


def test_unknown_names_without_close_matches() -> None:
    registry = ToolRegistry()
    registry.register(echo_spec("weather.get_forecast"))
    with pytest.raises(UnknownToolError) as raised:
        registry.get("zzz.qqq")
    assert raised.value.closest == [] and str(raised.value) == "unknown tool 'zzz.qqq'"
    with pytest.raises(UnknownToolError, match=r"did you mean 'weather\.get_forecast'"):
        registry.describe("weather.get_forecst")


def test_closest_lists_at_most_three_names_best_first() -> None:
    registry = ToolRegistry()
    for name in ("flight.goto", "flight.goto2", "flight.goto3", "flight.goto4", "camera.zoom"):
        registry.register(echo_spec(name))
    closest = registry.closest("flight.got")
    assert len(closest) == 3 and closest[0] == "flight.goto"
    assert "camera.zoom" not in closest


@pytest.mark.parametrize(
    "name",
    ["noperiod", "1math.add", "math..add", "math.add two", ".math", "math.", "math/add", "m." + "x" * 64, "", "é.x"],
)
def test_bad_names_are_refused(name: str) -> None:
    with pytest.raises(ToolDefinitionError, match="use a namespace and a name"):
        echo_spec(name)


@pytest.mark.parametrize("name", ["a.b", "weather.get-forecast", "flight.cmd.arm", "Ns_1.tool_2"])
def test_good_names_are_accepted(name: str) -> None:
    assert echo_spec(name).name == name


@pytest.mark.parametrize(
    ("input_schema", "output_schema", "message"),
    [
        (
            {"type": "object", "properties": {"lat": {"type": "latitude"}}},
            None,
            "the input schema is not valid JSON Schema at properties/lat/type",
        ),
        (
            {"type": "object", "required": "lat"},
            None,
            "the input schema is not valid JSON Schema at required",
        ),
        (
            {"type": "object"},
            {"type": "object", "properties": {"speed": {"minimum": "zero"}}},
            "the output schema is not valid JSON Schema at properties/speed/minimum",
        ),
        ({"type": "array"}, None, "the input schema must describe an object"),
    ],
)
def test_bad_schemas_name_the_place(input_schema: Any, output_schema: Any, message: str) -> None:
    with pytest.raises(ToolDefinitionError, match=re.escape(f"tool 'svc.bad': {message}")):
        ToolSpec.from_schema("svc.bad", lambda args: args, input_schema, output_schema=output_schema)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"timeout_s": 0}, "timeout_s must be positive"),
        ({"cache_ttl_s": 10}, "only idempotent tools may cache results"),
        ({"cache_ttl_s": -1, "idempotent": True}, "cache_ttl_s must be positive"),
        ({"scopes": ["flight command"]}, "bad scope 'flight command'"),
        ({"scopes": [""]}, "bad scope ''"),
        ({"scopes": "flight:command"}, "scopes must be a list"),
        ({"retry": 0}, "retry attempts must be at least 1"),
        ({"retry": "twice"}, "retry must be a number of attempts or a RetrySpec"),
        ({"rate_limit": "fast"}, "write it as COUNT/UNIT"),
        ({"rate_limit": "10/s", "burst": 0.5}, "burst must be at least 1"),
    ],
)
def test_bad_options_are_definition_errors(options: dict[str, Any], message: str) -> None:
    with pytest.raises(ToolDefinitionError, match=re.escape(message)):
        echo_spec("svc.bad", **options)


def test_registering_an_undecorated_function_is_an_error() -> None:
    def plain(a: int) -> int:
        return a

    with pytest.raises(ToolDefinitionError, match="'plain' is not a tool: decorate it with @tool"):
        ToolRegistry().register(plain)


def test_register_module() -> None:
    module = types.ModuleType("fleet_tools")

    @tool(name="fleet.count")
    def count() -> int:
        return 3

    @tool(name="fleet.ping")
    def ping(drone: str) -> str:
        return drone

    def helper() -> None:  # not a tool: left out
        pass

    module.count, module.ping, module.helper, module.VALUE = count, ping, helper, 3  # type: ignore[attr-defined]
    registry = ToolRegistry()
    assert sorted(registry.register_module(module)) == ["fleet.count", "fleet.ping"]
    assert registry.names() == ["fleet.count", "fleet.ping"]
    with pytest.raises(ToolDefinitionError, match="already registered"):
        registry.register_module(module)
    assert sorted(registry.register_module(module, replace=True)) == ["fleet.count", "fleet.ping"]


def test_subscribe_is_told_of_every_change_until_unsubscribed() -> None:
    registry = ToolRegistry()
    seen: list[list[str]] = []
    unsubscribe = registry.subscribe(lambda: seen.append(registry.names()))
    registry.register(echo_spec("svc.a"))
    registry.register(echo_spec("svc.b"))
    registry.register(echo_spec("svc.b"), replace=True)
    registry.unregister("svc.a")
    assert seen == [["svc.a"], ["svc.a", "svc.b"], ["svc.a", "svc.b"], ["svc.b"]]
    unsubscribe()
    registry.register(echo_spec("svc.c"))
    assert len(seen) == 4


def test_a_failed_registration_tells_no_listener() -> None:
    registry = ToolRegistry()
    registry.register(echo_spec("svc.a"))
    calls: list[None] = []
    registry.subscribe(lambda: calls.append(None))
    with pytest.raises(ToolDefinitionError):
        registry.register(echo_spec("svc.a"))
    assert calls == []


def test_names_by_namespace() -> None:
    registry = ToolRegistry()
    for name in ("weather.wind", "weather.rain", "flight.goto"):
        registry.register(echo_spec(name))
    assert registry.names() == ["flight.goto", "weather.rain", "weather.wind"]
    assert registry.names("weather") == ["weather.rain", "weather.wind"]
    assert registry.names("camera") == []
    assert registry.get("weather.wind").namespace == "weather"


def test_concurrent_registration_loses_no_tool() -> None:
    registry = ToolRegistry()
    barrier = threading.Barrier(8)

    def register(worker: int) -> None:
        barrier.wait()
        for i in range(25):
            registry.register(echo_spec(f"svc.t{worker}_{i}"))

    threads = [threading.Thread(target=register, args=(w,)) for w in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(registry) == 200


# describe and the catalogue ---------------------------------------------------------------------------------------
def test_describe_shows_guards_breaker_and_availability(clock: FakeClock) -> None:
    registry = ToolRegistry(clock=clock)

    @registered(
        registry,
        name="weather.wind",
        scopes=["weather:read"],
        rate_limit="20/s",
        caller_rate_limit="5/min",
        burst=4,
        timeout_s=2.5,
        retry=3,
        idempotent=True,
        cache_ttl_s=60,
        breaker=BreakerPolicy(failure_threshold=1, reset_timeout_s=10),
    )
    def wind(lat: float) -> float:
        """Wind speed in m/s.

        Args:
            lat: latitude in degrees
        """
        return 4.2

    description = registry.describe("weather.wind")
    assert isinstance(description, ToolDescription)
    assert description.model_dump() == {
        "name": "weather.wind",
        "description": "Wind speed in m/s.",
        "input_schema": {
            "additionalProperties": False,
            "properties": {"lat": {"description": "latitude in degrees", "title": "Lat", "type": "number"}},
            "required": ["lat"],
            "type": "object",
        },
        "output_schema": {"type": "number"},
        "scopes": ["weather:read"],
        "rate_limit": "20/s",
        "caller_rate_limit": "5/min",
        "timeout_s": 2.5,
        "retry_attempts": 3,
        "idempotent": True,
        "side_effects": False,
        "cache_ttl_s": 60,
        "source": "python",
        "breaker": "closed",
        "available": True,
    }
    entry = registry.entry("weather.wind")
    assert entry is not None and entry.limiter is not None
    assert entry.limiter.tool_limit is not None and entry.limiter.tool_limit.burst == 4
    entry.breaker.failure()
    assert registry.describe("weather.wind").breaker == "open"
    clock.advance(10)
    assert registry.describe("weather.wind").breaker == "half_open"


def test_describe_availability() -> None:
    registry = ToolRegistry()
    up = [True]

    def broken() -> bool:
        raise RuntimeError("probe failed")

    registry.register(echo_spec("svc.toggle", available=lambda: up[0]))
    registry.register(echo_spec("svc.broken", available=broken))
    assert registry.describe("svc.toggle").available is True
    up[0] = False
    assert registry.describe("svc.toggle").available is False
    assert registry.describe("svc.broken").available is False  # a failing check means unavailable, not a crash
    described = registry.describe("svc.broken")
    assert described.rate_limit is None and described.caller_rate_limit is None and described.cache_ttl_s is None


def test_catalogue_is_sorted_by_name(samples: ToolRegistry) -> None:
    catalogue = samples.catalogue()
    assert [d.name for d in catalogue] == ["flight.goto", "math.add", "svc.echo", "weather.wind"]
    assert all(isinstance(d, ToolDescription) for d in catalogue)
    assert catalogue[0].scopes == ["flight:command"] and catalogue[0].source == "schema"


# exports ----------------------------------------------------------------------------------------------------------
def test_to_openai_format(samples: ToolRegistry) -> None:
    exported = samples.to_openai()
    assert [e["function"]["name"] for e in exported] == ["flight__goto", "math__add", "svc__echo", "weather__wind"]
    goto = exported[0]
    assert goto == {
        "type": "function",
        "function": {
            "name": "flight__goto",
            "description": "Fly to a point.",
            "parameters": dict(samples.get("flight.goto").input_schema),
        },
    }
    assert exported[2]["function"]["description"] == "svc.echo"  # no description: the name stands in
    for entry in exported:
        assert set(entry) == {"type", "function"} and entry["type"] == "function"
        assert re.fullmatch(r"[A-Za-z0-9_-]{1,64}", entry["function"]["name"])
        assert entry["function"]["parameters"]["type"] == "object"


def test_resolve_maps_openai_names_back(samples: ToolRegistry) -> None:
    assert openai_name("weather.get_forecast") == "weather__get_forecast"
    assert samples.resolve("flight__goto") == "flight.goto"
    assert samples.resolve("flight.goto") == "flight.goto"
    assert samples.resolve("nothing__here") == "nothing__here"
    assert samples.get("weather__wind").name == "weather.wind"
    for entry in samples.to_openai():
        assert samples.resolve(entry["function"]["name"]) in samples


def test_an_openai_name_reaches_the_tool(samples: ToolRegistry) -> None:
    executor = ToolExecutor(samples)
    try:
        result = executor.call("math__add", {"a": 1, "b": 2})
    finally:
        executor.close()
    assert result.ok and result.output == 3 and result.tool == "math.add"


def test_to_mcp_format() -> None:
    registry = ToolRegistry()

    @registered(registry, name="sensor.read", idempotent=True)
    def read(channel: int) -> Reading:
        """Read a sensor channel."""
        return Reading(value=1.0, unit="V")

    @registered(registry, name="sensor.count")
    def count() -> int:
        return 2

    registry.register(
        ToolSpec.from_schema(
            "web.fetch",
            lambda args: "",
            {"type": "object", "properties": {"url": {"type": "string"}}},
            description="Fetch a page.",
            output_schema={"type": "object", "properties": {"text": {"type": "string"}}},
            source="http",
        )
    )
    exported = {e["name"]: e for e in registry.to_mcp()}
    assert list(exported) == ["sensor.count", "sensor.read", "web.fetch"]
    read_entry = exported["sensor.read"]
    assert read_entry["description"] == "Read a sensor channel."
    assert read_entry["inputSchema"] == dict(registry.get("sensor.read").input_schema)
    assert read_entry["outputSchema"]["type"] == "object"
    assert set(read_entry["outputSchema"]["properties"]) == {"value", "unit"}
    assert read_entry["annotations"] == {"idempotentHint": True, "openWorldHint": False}
    assert "outputSchema" not in exported["sensor.count"]  # MCP allows object output schemas only
    assert exported["sensor.count"]["description"] == "sensor.count"
    assert exported["web.fetch"]["annotations"] == {"idempotentHint": False, "openWorldHint": True}
    assert exported["web.fetch"]["outputSchema"] == {"type": "object", "properties": {"text": {"type": "string"}}}
    assert set(exported["web.fetch"]) == {"name", "description", "inputSchema", "outputSchema", "annotations"}


def test_openai_names_of_long_names_stay_within_64_characters() -> None:
    registry = ToolRegistry()
    long_name = "fleet.status_of_every_drone_in_the_hajj_corridor_by_sector_and_hour"[:64]
    registry.register(echo_spec(long_name))
    [exported] = registry.to_openai()
    assert re.fullmatch(r"[A-Za-z0-9_-]{1,64}", exported["function"]["name"])
    assert registry.resolve(exported["function"]["name"]) == long_name


def test_openai_names_are_unique() -> None:
    registry = ToolRegistry()
    registry.register(echo_spec("svc__a.b"))
    registry.register(echo_spec("svc.a__b"))
    exported = [e["function"]["name"] for e in registry.to_openai()]
    assert len(set(exported)) == 2  # otherwise the model cannot tell them apart
    assert sorted(registry.resolve(name) for name in exported) == ["svc.a__b", "svc__a.b"]


def test_a_handler_object_with_an_async_call_is_awaited() -> None:
    class Handler:
        async def __call__(self, args: dict[str, Any], context: Any) -> dict[str, Any]:
            return {"echo": args["x"]}

    registry = ToolRegistry()
    registry.register(ToolSpec.from_schema("demo.echo", Handler(), {"type": "object"}))
    assert registry.get("demo.echo").is_async
    executor = ToolExecutor(registry)
    try:
        assert executor.call("demo.echo", {"x": 1}).output == {"echo": 1}
    finally:
        executor.close()


def test_unsubscribing_twice_is_harmless() -> None:
    registry = ToolRegistry()
    seen: list[int] = []
    stop = registry.subscribe(lambda: seen.append(1))
    registry.register(ToolSpec.from_schema("demo.a", lambda args: 1, {"type": "object"}))
    stop()
    stop()
    registry.register(ToolSpec.from_schema("demo.b", lambda args: 1, {"type": "object"}))
    assert seen == [1]
