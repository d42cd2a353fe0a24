"""JSON with a depth limit: input nested deeper than :data:`MAX_JSON_DEPTH` is a clear error, never a
``RecursionError`` traceback from the parser or from the code that walks the value later.

>>> loads('{"a": [1, 2]}')
{'a': [1, 2]}
>>> try:
...     loads("[" * 5000 + "]" * 5000)
... except JsonTooDeep as exc:
...     print(exc)
JSON nested more than 100 levels deep
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from .errors import InputError

MAX_JSON_DEPTH = 100


class JsonTooDeep(InputError, ValueError):
    """JSON nested deeper than the limit (a ``ValueError``, as a parse error is)."""


def depth_of(value: Any, limit: int = MAX_JSON_DEPTH) -> int:
    """How deeply lists and dicts nest in ``value`` (a scalar is 0), counted without recursion up to ``limit + 1``."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, dict | list):
            depth += 1
            deepest = max(deepest, depth)
            if depth > limit:
                return depth
            stack.extend((child, depth) for child in (item.values() if isinstance(item, dict) else item))
    return deepest


def loads(text: str | bytes, max_depth: int = MAX_JSON_DEPTH, *, parse_int: Callable[[str], Any] | None = None) -> Any:
    """``json.loads`` that refuses input nested more than ``max_depth`` levels (:class:`JsonTooDeep`);
    ``parse_int``, as ``json.loads`` takes it, turns each integer's digits into a value."""
    too_deep = JsonTooDeep(f"JSON nested more than {max_depth} levels deep")
    try:
        value = json.loads(text, parse_int=parse_int)
    except RecursionError:
        raise too_deep from None
    if depth_of(value, max_depth) > max_depth:
        raise too_deep
    return value


__all__ = ["MAX_JSON_DEPTH", "JsonTooDeep", "depth_of", "loads"]
