"""A fast yes/no for the commonest argument schema: a flat object of strings, numbers, integers and booleans.

jsonschema stays the authority: this only answers "valid" when jsonschema would (and no number is NaN or
infinite, which the executor refuses besides), for schemas it fully understands, and the executor asks jsonschema
for the errors whenever it says anything else. It saves most of the cost of validating a typical tool's arguments
on every call.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from math import isfinite
from typing import Any

_SCHEMA_KEYS = {"type", "properties", "required", "additionalProperties", "title", "description", "$schema"}
_PROPERTY_KEYS = {"type", "title", "description", "default"}


def _is_integer(value: Any) -> bool:
    if isinstance(value, bool):
        return False
    return isinstance(value, int) or (isinstance(value, float) and value.is_integer())  # JSON Schema: 1.0 is one


_TYPES: dict[str, Callable[[Any], bool]] = {
    "string": lambda v: isinstance(v, str),
    "integer": _is_integer,
    "number": lambda v: (isinstance(v, int) and not isinstance(v, bool)) or (isinstance(v, float) and isfinite(v)),
    "boolean": lambda v: isinstance(v, bool),
}


def _plain(value: Any) -> bool:
    """An argument the schema does not describe, passed by the quick check: not a container (it might hold a NaN
    deep inside), not a NaN or an infinity."""
    if isinstance(value, float):
        return isfinite(value)
    return not isinstance(value, Mapping | list | tuple)


def flat_checker(schema: Mapping[str, Any]) -> Callable[[Mapping[str, Any]], bool] | None:
    """A function that is True only for arguments the schema accepts, or None when the schema is not flat."""
    if set(schema) - _SCHEMA_KEYS or schema.get("type", "object") != "object":
        return None
    properties = schema.get("properties", {})
    extra = schema.get("additionalProperties", True)
    required = schema.get("required", [])
    if not isinstance(properties, Mapping) or extra not in (True, False) or not isinstance(required, list):
        return None
    checks: dict[str, Callable[[Any], bool]] = {}
    for name, prop in properties.items():
        if not isinstance(prop, Mapping) or set(prop) - _PROPERTY_KEYS or prop.get("type") not in _TYPES:
            return None
        checks[name] = _TYPES[prop["type"]]
    needed = tuple(required)
    closed = extra is False

    def check(args: Mapping[str, Any]) -> bool:
        for name in needed:
            if name not in args:
                return False
        for name, value in args.items():
            test = checks.get(name)
            if test is None:
                if closed or not _plain(value):
                    return False
            elif not test(value):
                return False
        return True

    return check
