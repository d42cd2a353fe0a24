"""Tools the corpus missions call that are not built in; ``agentic-uav validate --tools`` registers them."""

from typing import Any

from tools import ToolSpec

OPEN_OBJECT: dict[str, Any] = {"type": "object", "additionalProperties": True}

log_density = ToolSpec.from_schema("crowd.log_density", lambda args: {"logged": True}, OPEN_OBJECT)
record = ToolSpec.from_schema("survey.record", lambda args: {"recorded": True}, OPEN_OBJECT)


def register(registry: Any) -> None:
    registry.register(log_density)
    registry.register(record)
