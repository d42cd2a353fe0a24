"""A call's arguments checked: the quick check for flat schemas, else jsonschema, and no NaN or infinity anywhere.

NaN and the infinities are no JSON, yet Python floats carry them, and JSON Schema's ``number`` accepts any float:
``nan`` would pass the schema and reach the tool (a flight tool's own model then fails with a long pydantic error).
They are refused here with the other invalid arguments, in the same one-line form.

>>> non_finite({"lat": float("nan"), "path": [{"alt_m": 10.0}, {"alt_m": float("-inf")}], "n": 3})
[('$.lat', nan), ('$.path[1].alt_m', -inf)]
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .registry import RegisteredTool

SHOWN = 3  # problems named in one error; the rest counted


def argument_errors(entry: RegisteredTool, args: dict[str, Any]) -> str | None:
    """Why ``args`` are invalid for the tool, as ``$.path: message`` for the first three problems; None if valid.

    >>> from tools import ToolRegistry
    >>> registry = ToolRegistry()
    >>> @registry.tool(name="geo.go")
    ... def go(lat: float, lon: float) -> None:
    ...     pass
    >>> argument_errors(registry.entry("geo.go"), {"lat": float("nan"), "lon": "east"})
    "$.lat: nan is not a finite number; $.lon: 'east' is not of type 'number'"
    """
    quick = entry.quick_check
    if quick is not None and quick(args):  # it passes finite numbers only
        return None
    errors = [(error.json_path, error.message) for error in entry.validator.iter_errors(args)]
    errors += [(where, f"{value} is not a finite number") for where, value in non_finite(args)]
    if not errors:
        return None
    errors.sort(key=lambda error: error[0])
    detail = "; ".join(f"{where}: {message}" for where, message in errors[:SHOWN])
    return detail + (f" (and {len(errors) - SHOWN} more)" if len(errors) > SHOWN else "")


def non_finite(args: Mapping[str, Any], limit: int = 100) -> list[tuple[str, float]]:
    """The JSON paths and values of the first ``limit`` NaN or infinite floats in ``args``, at any depth (lists,
    tuples and mappings walked without recursion, each container once)."""
    found: list[tuple[str, float]] = []
    stack: list[tuple[Any, str]] = [(args, "$")]
    seen: set[int] = set()
    while stack and len(found) < limit:
        node, path = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        items = node.items() if isinstance(node, Mapping) else enumerate(node)
        nested: list[tuple[Any, str]] = []
        for key, value in items:
            where = f"{path}[{key}]" if isinstance(key, int) else f"{path}.{key}"
            if isinstance(value, float):
                if not math.isfinite(value):
                    found.append((where, value))
            elif isinstance(value, Mapping | list | tuple):
                nested.append((value, where))
        stack.extend(reversed(nested))
    found.sort(key=lambda item: item[0])
    return found[:limit]


__all__ = ["argument_errors", "non_finite"]
