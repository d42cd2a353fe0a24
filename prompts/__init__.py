"""Prompt templates and the JSON Schemas of structured LLM outputs, shipped as package data.

Templates (``prompts/templates/*.md``) use ``${name}`` placeholders (:class:`string.Template`), so JSON braces in
the values need no escaping; a placeholder without a value is an error, never a silent blank. Schemas
(``prompts/schemas/*.schema.json``) are generated from the pydantic contracts and tested to stay current.

>>> "World Model" in render("assess", goal="patrol", time_s=12.5, ego="30 m above home", focus_line="",
...                         world_model="{}", knowledge="")
True
>>> sorted(schema("assessment")["required"])
['confidence', 'persons_detected']
"""

from __future__ import annotations

import json
from functools import cache
from importlib import resources
from string import Template
from typing import Any

from agentic_core.contracts.errors import AgenticUAVError

TEMPLATES = ("system", "assess", "plan", "reflect")
SCHEMAS = ("assessment", "plan")


class PromptError(AgenticUAVError, KeyError):
    """A template or schema that does not exist, or a placeholder given no value."""

    def __str__(self) -> str:
        return str(self.args[0])


@cache
def template(name: str) -> str:
    """The text of one template, e.g. ``template("system")``."""
    if name not in TEMPLATES:
        raise PromptError(f"no prompt template {name!r}; there are: {', '.join(TEMPLATES)}")
    return resources.files(__package__).joinpath("templates", f"{name}.md").read_text(encoding="utf-8")


def render(name: str, **values: Any) -> str:
    """A template with its ``${placeholders}`` filled; every placeholder must be given."""
    try:
        return Template(template(name)).substitute({key: str(value) for key, value in values.items()})
    except KeyError as exc:
        raise PromptError(f"prompt template {name!r} needs a value for ${{{exc.args[0]}}}") from None


@cache
def _schema_text(name: str) -> str:
    if name not in SCHEMAS:
        raise PromptError(f"no output schema {name!r}; there are: {', '.join(SCHEMAS)}")
    return resources.files(__package__).joinpath("schemas", f"{name}.schema.json").read_text(encoding="utf-8")


def schema(name: str) -> dict[str, Any]:
    """The JSON Schema of one structured output (a fresh copy each call)."""
    loaded: dict[str, Any] = json.loads(_schema_text(name))
    return loaded


__all__ = ["SCHEMAS", "TEMPLATES", "PromptError", "render", "schema", "template"]
