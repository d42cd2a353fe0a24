"""A mission's parameters and its initial graph state: what a compiled mission is run with, not part of compiling."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from .model import PolicyGraph

if TYPE_CHECKING:
    from .compile import MissionState  # the return type only: params need no graph runtime


def parse_param(plan: PolicyGraph, name: str, text: Any) -> Any:
    """A parameter value from the command line (text) or from code, checked against its declaration."""
    spec = plan.params.get(name)
    if spec is None:
        known = ", ".join(plan.params) or "none"
        raise ValueError(f"unknown parameter {name!r}; the mission has: {known}")
    value = text
    try:
        if spec.type == "number":
            value = float(text)
            if not math.isfinite(value):
                raise ValueError
        elif spec.type == "integer":
            value = int(text)
        elif spec.type == "boolean":
            value = text if isinstance(text, bool) else str(text).strip().lower() in ("1", "true", "yes", "on")
        elif spec.type == "position" and isinstance(text, str):
            lat, lon = (float(v) for v in text.split(","))
            value = {"lat": lat, "lon": lon}
    except (TypeError, ValueError):
        article = "an" if spec.type[0] in "aeiou" else "a"
        raise ValueError(f"parameter {name!r} is {article} {spec.type}, not {text!r}") from None
    problem = spec.out_of_bounds(value)
    if problem:
        raise ValueError(f"parameter {name!r} {problem}")
    return value


def initial_state(plan: PolicyGraph, overrides: Mapping[str, Any] | None = None) -> MissionState:
    """The state a mission starts from: parameter defaults, overridden (and type-checked) by ``overrides``."""
    params = {name: p.default for name, p in plan.params.items()}
    for name, value in (overrides or {}).items():
        params[name] = parse_param(plan, name, value)
    missing = [name for name, value in params.items() if value is None]
    if missing:
        given = " ".join(f"--param {name}=..." for name in missing)
        raise ValueError(f"parameter(s) {', '.join(missing)} have no default and were not given: {given}")
    return {"params": params, "outputs": {}, "status": {}, "fired": [], "log": [], "reflections": 0}
