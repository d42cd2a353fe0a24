"""The text of an item to index: the fields named by paths such as ``"text"``, ``"a.b"``, ``"notes[*].body"``,
``"notes[0].body"`` or ``"$"`` (the whole value as JSON). Each piece of text found is indexed on its own.

>>> texts_at({"notes": [{"body": "heat"}, {"body": "crush"}]}, "notes[*].body")
['heat', 'crush']
>>> texts_at({"a": {"b": 3}}, "a.b"), texts_at({"a": 1}, "missing")
(['3'], [])
"""

from __future__ import annotations

import json
import re
from typing import Any

from agentic_core.contracts.errors import InputError

_TOKEN = re.compile(r"([^.\[\]]+)|\[(\*|-?\d+)\]")


def tokens(path: str) -> list[str | int]:
    """A path split into field names, indices (int) and ``"*"`` for every element; InputError if malformed."""
    out: list[str | int] = []
    pos = 0
    for m in _TOKEN.finditer(path):
        between = path[pos : m.start()]
        if between not in ("", "."):
            raise InputError(f"index path {path!r}: cannot read {between!r} at position {pos}")
        name, index = m.groups()
        out.append(name if name is not None else ("*" if index == "*" else int(index)))
        pos = m.end()
    if pos != len(path) or not out:
        raise InputError(f"index path {path!r}: expected names joined by '.', with [n] or [*] for lists")
    return out


def texts_at(value: Any, path: str) -> list[str]:
    """Every piece of text found at ``path`` in ``value`` (objects and lists as JSON; ``None`` skipped)."""
    if path == "$":
        return [json.dumps(value, sort_keys=True, ensure_ascii=False)]
    return _walk(value, tokens(path))


def _walk(node: Any, rest: list[str | int]) -> list[str]:
    if not rest:
        if node is None:
            return []
        if isinstance(node, str | int | float | bool):
            return [str(node)]
        return [json.dumps(node, sort_keys=True, ensure_ascii=False)]
    head, tail = rest[0], rest[1:]
    if head == "*" and isinstance(node, list):
        return [t for element in node for t in _walk(element, tail)]
    if isinstance(head, int) and isinstance(node, list):
        return _walk(node[head], tail) if -len(node) <= head < len(node) else []
    if isinstance(head, str) and isinstance(node, dict) and head in node:
        return _walk(node[head], tail)
    return []
