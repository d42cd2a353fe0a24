"""What the tool returns: validation against its output schema and the injection guard on untrusted or suspicious
output."""

from typing import Any

from tools import MemoryAuditLog, ToolRegistry

from .conftest import INJECTION, registered, stage, stage_names
from .executor_fixtures import BEFORE_TOOL, MakeExecutor, schema_tool


# output validation ------------------------------------------------------------------------------------------------
def test_output_schema_mismatch_of_a_schema_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    output_schema = {"type": "object", "properties": {"speed": {"type": "number"}}, "required": ["speed"]}
    answers: list[Any] = [{"speed": "fast"}, {"speed": 3.5}]
    schema_tool(registry, "weather.speed", lambda args: answers.pop(0), output_schema=output_schema)
    executor = make_executor(registry)
    bad = executor.call("weather.speed", {})
    assert bad.status == "error" and bad.output is None
    assert bad.error == "the tool's output does not match its schema: $.speed: 'fast' is not of type 'number'"
    assert stage_names(bad) == [
        *BEFORE_TOOL,
        "circuit_breaker:passed",
        "invoke:passed",
        "validate_output:failed",
        "audit:passed",
    ]
    good = executor.call("weather.speed", {})
    assert good.ok and good.output == {"speed": 3.5}


def test_output_schema_mismatch_of_a_function_tool(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    @registered(registry, name="weather.speeds")
    def speeds() -> list[float]:
        return [1.0, "gusty"]  # type: ignore[list-item]

    result = make_executor(registry).call("weather.speeds", {})
    assert result.status == "error" and result.error is not None
    assert result.error.startswith("the tool's output does not match its schema: $[1]:")
    assert stage(result, "validate_output").outcome == "failed"


def test_an_output_that_cannot_be_serialised_is_an_output_error(
    registry: ToolRegistry, make_executor: MakeExecutor
) -> None:
    @registered(registry, name="svc.blob")
    def blob() -> dict[str, Any]:
        return {"handle": object()}  # no JSON form

    audit = MemoryAuditLog()
    result = make_executor(registry, audit=audit).call("svc.blob", {})
    assert result.status == "error"
    assert stage_names(result)[-2:] == ["validate_output:failed", "audit:passed"]
    assert [r.status for r in audit.records] == ["error"]  # the audit log holds every call


# injection guard --------------------------------------------------------------------------------------------------
def test_instructions_in_output_are_flagged(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: {"items": [{"text": INJECTION}]})
    result = make_executor(registry).call("web.fetch", {})
    assert result.ok and result.output == {"items": [{"text": INJECTION}]}
    assert result.untrusted is True and result.injection is not None and result.injection.flagged
    assert any(f.path == "$.items[0].text" for f in result.injection.findings)
    assert stage_names(result) == [
        *BEFORE_TOOL,
        "circuit_breaker:passed",
        "invoke:passed",
        "validate_output:passed",
        "injection_guard:flagged",
        "audit:passed",
    ]
    assert stage(result, "injection_guard").detail == f"score {result.injection.score}"


def test_withheld_output(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION)
    result = make_executor(registry, on_injection="withhold").call("web.fetch", {})
    assert result.status == "error" and result.output is None
    assert result.error == "output withheld: it looks like instructions"
    assert result.injection is not None and result.untrusted
    assert stage(result, "injection_guard").outcome == "flagged"


def test_clean_and_untrusted_outputs(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: "Wind 12 kt, gusts 20.", untrusted_output=True)
    schema_tool(registry, "svc.local", lambda args: "Wind 12 kt, gusts 20.")
    executor = make_executor(registry)
    fetched = executor.call("web.fetch", {})
    assert fetched.ok and fetched.untrusted is True and fetched.injection is None
    assert stage(fetched, "injection_guard").outcome == "passed"
    local = executor.call("svc.local", {})
    assert local.untrusted is False and local.injection is None


def test_a_threshold_above_the_score_lets_it_through(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION)
    result = make_executor(registry, injection_threshold=1.0).call("web.fetch", {})
    assert result.ok and result.injection is None and stage(result, "injection_guard").outcome == "passed"


def test_a_cached_flagged_output_stays_flagged(registry: ToolRegistry, make_executor: MakeExecutor) -> None:
    schema_tool(registry, "web.fetch", lambda args: INJECTION, idempotent=True, cache_ttl_s=60)
    executor = make_executor(registry)
    first = executor.call("web.fetch", {"url": "https://example.org"})
    assert first.injection is not None
    again = executor.call("web.fetch", {"url": "https://example.org"})
    assert again.cached
    assert again.injection is not None and again.untrusted  # a cache hit must not launder the output
