"""Checking ``call_tool`` steps against the tool catalogue before take-off: the tool exists (else the closest
names), and the arguments written in the mission fit the tool's input schema. A value holding ``${...}`` is
known only at run time, so a complaint about that value itself is left to the executor; the rest (required
fields, unknown fields, literal values) is checked here. A mission's ``scopes:`` must hold what the run itself
calls (:data:`RUN_TOOLS`) and every tool its steps call (:func:`missing_scopes`).

>>> missing_scopes(["flight:command"], {"flight.status": ("flight:read",), "flight.fly_to": ("flight:command",)})
{'flight:read': ['flight.status']}
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Iterator, Mapping
from typing import Any, Protocol

import jsonschema

from agentic_core.contracts.policy_graph import ON_ABORT_TOOLS
from tools.auth import Caller

ArgPath = tuple[str | int, ...]
Validators = dict[str, jsonschema.protocols.Validator]
"""Schema validators kept by tool name, so that a mission calling one tool many times builds its validator once."""


class ToolCatalog(Protocol):
    """What validation needs of a tool registry (``tools.ToolRegistry`` is one)."""

    def __contains__(self, name: object) -> bool: ...
    def names(self) -> list[str]: ...
    def input_schema(self, name: str) -> Mapping[str, Any]: ...
    def get(self, name: str) -> Scoped: ...


class Scoped(Protocol):
    """A tool as the scope check sees it (``tools.ToolSpec`` is one)."""

    @property
    def scopes(self) -> tuple[str, ...]: ...


RUN_TOOLS = frozenset({"flight.status", "flight.set_fence", "flight.hold", *ON_ABORT_TOOLS.values()})
"""What the run itself calls, whatever the mission: reach the vehicle, hand it the fence, stop, come home, land."""


def missing_scopes(held: Iterable[str], needs: Mapping[str, Iterable[str]]) -> dict[str, list[str]]:
    """Each scope of ``needs`` (tool -> the scopes it asks) that ``held`` lacks, with the tools that ask it."""
    caller = Caller(id="mission", scopes=frozenset(held))  # the very rule the executor applies
    missing: dict[str, list[str]] = {}
    for tool, scopes in needs.items():
        for scope in caller.missing(scopes):
            missing.setdefault(scope, []).append(tool)
    return missing


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
