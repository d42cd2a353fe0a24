"""A model's output, capped in size before it reaches the trace, a prompt or an e-mail: a 5 MB "assessment" is
cut to :data:`MAX_OUTPUT_CHARS` (64 KiB of text by default; ``AGENTIC_UAV_LLM_MAX_OUTPUT_CHARS`` sets another).

A structured reply is parsed whole, then its text is shared out: each string, in order, keeps what is left of the
budget, the rest cut with :data:`CUT` after it; list items past the budget are dropped. Numbers, booleans and
keys cost what they print as. A cut reply is still the same shape, so the schema still judges it.

>>> cap_value({"severity": "critical", "rationale": "x" * 100}, 40)["rationale"]
'xxxxxxxxxxxxxxx… [cut]'
>>> cap_text("y" * 10, 4)
'yyyy… [cut]'
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

MAX_OUTPUT_CHARS = 64 * 1024
"""The default cap on a model's reply, in characters."""
ENV = "AGENTIC_UAV_LLM_MAX_OUTPUT_CHARS"
CUT = "… [cut]"


def max_output_chars(environ: Mapping[str, str] | None = None) -> int:
    """The cap in force: ``AGENTIC_UAV_LLM_MAX_OUTPUT_CHARS`` when it is a positive whole number, else the default."""
    raw = (os.environ if environ is None else environ).get(ENV, "").strip()
    return int(raw) if raw.isdigit() and int(raw) > 0 else MAX_OUTPUT_CHARS


def cap_text(text: str, limit: int) -> str:
    """``text``, cut to ``limit`` characters (and marked) when longer."""
    return text if len(text) <= limit else text[:limit] + CUT


def cap_value(value: Any, limit: int) -> Any:
    """A parsed JSON value with its text shared out within ``limit`` characters (see the module docstring)."""
    return _cap(value, [limit])


def _cap(value: Any, budget: list[int]) -> Any:
    if isinstance(value, str):
        kept = cap_text(value, max(budget[0], 0))
        budget[0] -= len(value)
        return kept
    if isinstance(value, list):
        out: list[Any] = []
        for item in value:
            if budget[0] <= 0 and out:
                break
            out.append(_cap(item, budget))
        return out
    if isinstance(value, dict):
        capped: dict[Any, Any] = {}
        for key, item in value.items():
            budget[0] -= len(str(key))
            capped[key] = _cap(item, budget)
        return capped
    budget[0] -= len(str(value))
    return value


__all__ = ["CUT", "ENV", "MAX_OUTPUT_CHARS", "cap_text", "cap_value", "max_output_chars"]
