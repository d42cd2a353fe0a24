"""Tool calls hidden in structured data: a JSON object, anywhere in a tool's output, shaped like a call to a tool.

The shapes are those models and agent frameworks exchange: OpenAI's ``tool_calls`` (``{"id", "type": "function",
"function": {"name", "arguments": "<JSON text>"}}``) and its older ``function_call``, Anthropic's ``tool_use``
blocks (``{"type": "tool_use", "name", "input"}``), and the generic ``{"tool": ..., "arguments": ...}`` with its
spellings (``tool_name``, ``function``, ``command``, ``action``; ``args``, ``parameters``, ``params``, ``input``).
A record of a call already made (it has a status, a result, a latency or a call id) and a tool's definition (its
``parameters`` are a JSON Schema) are not calls: they weigh little.

>>> [(c.path, c.weight) for c in calls({"next": {"tool": "flight.land", "arguments": {"lat": 21.4}}})]
[('$.next', 0.8)]
>>> calls({"calls": [{"tool": "flight.land", "args": {}, "status": "ok", "latency_s": 3.1}]})[0].weight
0.2
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

NAME_KEYS = ("tool", "tool_name", "function", "function_name", "recipient_name", "command", "action", "call", "name")
ARG_KEYS = ("arguments", "args", "parameters", "params", "input", "tool_input", "kwargs")
CALL_LIST_KEYS = frozenset({"tool_calls", "function_call", "tool_call", "toolcalls", "function_calls"})
RECORD_KEYS = frozenset(
    {
        "status",
        "result",
        "results",
        "output",
        "latency_s",
        "latency",
        "call_id",
        "error",
        "duration_s",
        "ok",
        "returned",
    }
)
SCHEMA_KEYS = frozenset({"properties", "$schema", "required", "additionalProperties"})
_NAMESPACED = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{0,40}(?:\.|__|/|:)[A-Za-z][A-Za-z0-9_.-]{0,60}$")
_IDENTIFIER = re.compile(r"^[A-Za-z][A-Za-z0-9_-]{1,60}$")
_VERB = re.compile(
    r"^(?:send|fly|land|set|delete|disable|enable|arm|disarm|deploy|release|upload|post|call|execute|run|transfer"
    r"|email|goto|go|takeoff|take|start|stop|cancel|abort|update|write|create|remove|grant|open|drop|return|rtl|hold"
    r"|exec|invoke|forward|share|publish|download|fetch|read|get|list|approve|override|reset|erase|wipe)(?:_|$)",
    re.IGNORECASE,
)
MAX_JSON_TEXT = 100_000  # a string longer than this is not parsed for structure (its text is still scanned)


@dataclass(frozen=True, slots=True)
class Call:
    """A call-shaped object at ``path``: the tool it names and how much it weighs as an injection cue."""

    path: str
    tool: str
    weight: float

    @property
    def excerpt(self) -> str:
        return f"tool call to {self.tool}"[:80]


def _child(path: str, key: object) -> str:
    if isinstance(key, str) and key.isidentifier() and key.isascii():
        return f"{path}.{key}"
    if isinstance(key, str):
        escaped = key.replace("\\", "\\\\").replace("'", "\\'")
        return f"{path}['{escaped}']"
    return f"{path}[{key!r}]"


def _arguments(value: object) -> bool:
    """Whether ``value`` can be a call's arguments: an object (not a JSON Schema), or JSON text of one."""
    if isinstance(value, Mapping):
        return not SCHEMA_KEYS.intersection(k for k in value if isinstance(k, str))
    if isinstance(value, str):
        text = value.strip()
        if text.startswith("{") and text.endswith("}") and len(text) <= MAX_JSON_TEXT:
            parsed = loads(text)
            return isinstance(parsed, dict) and not SCHEMA_KEYS.intersection(parsed)
    return False


def _call_in(node: Mapping[Any, Any]) -> tuple[str, float] | None:
    """The tool a mapping calls and its weight, if it is shaped like a call."""
    keys = {k for k in node if isinstance(k, str)}
    if keys & CALL_LIST_KEYS:
        key = sorted(keys & CALL_LIST_KEYS)[0]
        return key, 0.85 if node[key] else 0.0
    if node.get("type") == "tool_use" and isinstance(node.get("name"), str):
        return str(node["name"]), 0.8
    name_key = next((k for k in NAME_KEYS if isinstance(node.get(k), str)), None)
    arg_key = next((k for k in ARG_KEYS if k in node and _arguments(node[k])), None)
    if name_key is None or arg_key is None:
        return None
    tool = str(node[name_key]).strip()
    if not _IDENTIFIER.match(tool) and not _NAMESPACED.match(tool):
        return None
    if keys & RECORD_KEYS or "description" in keys:
        return tool, 0.2  # a record of a call made, or a tool's definition
    shaped = _NAMESPACED.match(tool) is not None or _VERB.match(tool) is not None
    return tool, 0.8 if shaped or name_key != "name" else 0.35


def loads(text: str) -> object:
    """``text`` parsed as JSON, or None when it is not JSON (or nests too deep to parse)."""
    try:
        return json.loads(text)
    except (ValueError, RecursionError):
        return None


def calls(value: object, path: str = "$") -> list[Call]:
    """Every call-shaped mapping in ``value`` (walked without recursion; shared containers once)."""
    return list(_walk(value, path))


def _walk(value: object, path: str) -> Iterator[Call]:
    stack: list[tuple[object, str]] = [(value, path)]
    seen: set[int] = set()
    while stack:
        node, where = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if isinstance(node, Mapping):
            found = _call_in(node)
            if found is not None and found[1] > 0.0:
                yield Call(where, found[0], found[1])
            stack.extend((item, _child(where, key)) for key, item in node.items() if _container(item))
        elif isinstance(node, (list, tuple)):
            stack.extend((item, f"{where}[{i}]") for i, item in enumerate(node) if _container(item))


def _container(item: object) -> bool:
    return isinstance(item, (Mapping, list, tuple))


def calls_in_text(text: str) -> list[Call]:
    """The call-shaped objects in ``text`` when it is a JSON object or array (paths rooted at ``$``)."""
    stripped = text.strip()
    if len(stripped) > MAX_JSON_TEXT or stripped[:1] not in ("{", "[") or stripped[-1:] not in ("}", "]"):
        return []
    parsed = loads(stripped)
    return calls(parsed) if _container(parsed) else []


__all__ = ["Call", "calls", "calls_in_text", "loads"]
