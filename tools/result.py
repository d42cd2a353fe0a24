"""The ToolResult contract (defined in :mod:`agentic_core.contracts.tool_result`, re-exported here) and the
executor's fast constructor for it.

>>> values = dict(status="ok", output=1, error=None, latency_s=0.0, attempts=1, call_id="c", tool="t", caller=None,
...               cached=False, replayed=False, retry_after_s=None, stages=[], untrusted=False, injection=None)
>>> construct(ToolResult, values) == ToolResult(**values)
True
"""

from __future__ import annotations

from typing import Any, TypeVar

from pydantic import BaseModel

from agentic_core.contracts.tool_result import (
    Stage,
    StageName,
    StageOutcome,
    ToolResult,
    ToolStatus,
    tool_result_json_schema,
)

M = TypeVar("M", bound=BaseModel)


def construct(model: type[M], values: dict[str, Any]) -> M:
    """A model from values the executor built itself, every field given and already of its type: what
    ``model_construct`` does, without its per-field loop (a fifth of a no-op call's overhead)."""
    instance = model.__new__(model)
    object.__setattr__(instance, "__dict__", values)
    object.__setattr__(instance, "__pydantic_fields_set__", set(values))
    object.__setattr__(instance, "__pydantic_extra__", None)
    object.__setattr__(instance, "__pydantic_private__", None)
    return instance


__all__ = ["Stage", "StageName", "StageOutcome", "ToolResult", "ToolStatus", "construct", "tool_result_json_schema"]
