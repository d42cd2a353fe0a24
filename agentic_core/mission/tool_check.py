"""Checking ``call_tool`` steps against the tool catalogue before take-off: the tool exists (else the closest
names), and the arguments written in the mission fit the tool's input schema. A value holding ``${...}`` is
known only at run time, so a complaint about that value itself is left to the executor; the rest (required
fields, unknown fields, literal values) is checked here."""

from __future__ import annotations

import difflib
from collections.abc import Iterator, Mapping
from typing import Any, Protocol

import jsonschema

ArgPath = tuple[str | int, ...]
Validators = dict[str, jsonschema.protocols.Validator]
"""Schema validators kept by tool name, so that a mission calling one tool many times builds its validator once."""


class ToolCatalog(Protocol):
    """What validation needs of a tool registry (``tools.ToolRegistry`` is one)."""

    def __contains__(self, name: object) -> bool: ...
    def names(self) -> list[str]: ...
    def input_schema(self, name: str) -> Mapping[str, Any]: ...


def unknown_tool_message(name: str, catalog: ToolCatalog) -> str:
    closest = difflib.get_close_matches(name, catalog.names(), n=3, cutoff=0.5)
    hint = f"; did you mean {', '.join(repr(c) for c in closest)}?" if closest else ""
    return f"unknown tool {name!r}: no such tool is registered{hint}"


def argument_problems(
    name: str,
    args: Mapping[str, Any],
    catalog: ToolCatalog,
    validators: Validators | None = None,
) -> Iterator[tuple[ArgPath, str]]:
    """``(path inside args, message)`` for each way the written arguments break the tool's input schema.

    ``validators`` keeps each tool's schema validator between calls (by tool name), for a mission that calls
    the same tool many times: building one costs more than checking a step's arguments with it."""
    validator = validators.get(name) if validators is not None else None
    if validator is None:
        validator = jsonschema.Draft202012Validator(catalog.input_schema(name))
        if validators is not None:
            validators[name] = validator
    for error in validator.iter_errors(dict(args)):
        if isinstance(error.instance, str) and "${" in error.instance:
            continue  # its value, even its type, is known only when the step runs
        yield tuple(error.absolute_path), f"{name}: {error.message}"
