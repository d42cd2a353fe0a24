"""Least privilege for one run: the agent holds only the scopes its mission needs, and a model's plan may call only
the tools the mission itself uses or lists in ``allow_tools``.

The scopes are the mission's ``scopes:`` when it declares them, else those of every tool its steps and triggers
call (plus what the run itself sends the vehicle: status, the fence, hold, return, land). A model that proposes a
webhook to an arbitrary URL in a mission that never posts one is refused with the reason, before any of it runs;
so is a plan whose alerts are addressed off the configured allowlists (:func:`destination_review`).

>>> from agentic_core.mission.validate import load_mission
>>> plan = load_mission("plan_id: P\\ngoal: g\\nsteps: [{id: up, action: takeoff}, {id: look, action: analyze_scene}]")
>>> sorted(mission_tools(plan) - RUN_TOOLS)
['flight.takeoff', 'perception.analyze_scene']
"""

from __future__ import annotations

from collections.abc import Iterable

from pydantic import BaseModel

from tools import Caller, ToolRegistry
from tools.builtin.allowlist import destination_problems
from tools.builtin.config import BuiltinConfig

from ..mission.model import PolicyGraph, Step
from ..mission.tool_check import RUN_TOOLS
from ..mission.validate import iter_steps, step_tool, walk_steps

ALLOWED_WHY = "its steps' tools and allow_tools"


def mission_tools(plan: PolicyGraph) -> frozenset[str]:
    """Every tool the mission's own steps and triggers call, and what the run calls for it."""
    return frozenset({t for site in iter_steps(plan) if (t := step_tool(site.step)) is not None} | RUN_TOOLS)


def plan_tools(plan: PolicyGraph) -> frozenset[str]:
    """The tools a model's plan or revision may call: the mission's own and its ``allow_tools``."""
    return mission_tools(plan) | frozenset(plan.allow_tools)


def mission_caller(plan: PolicyGraph, registry: ToolRegistry, name: str = "agent") -> Caller:
    """The agent as the mission's caller: its declared ``scopes``, else what the tools of :func:`plan_tools` ask."""
    if plan.scopes is not None:
        return Caller(id=name, scopes=frozenset(plan.scopes))
    needed = {scope for tool in plan_tools(plan) if tool in registry for scope in registry.get(tool).scopes}
    return Caller(id=name, scopes=frozenset(needed))


def tool_problems(steps: Iterable[Step], allowed: frozenset[str], why: str | None = None) -> list[str]:
    """A reason for each step of a model's plan calling a tool outside ``allowed`` (empty: none does); ``why``
    says what ``allowed`` is (default: the mission's steps' tools and ``allow_tools``)."""
    problems = []
    for site in walk_steps(list(steps)):
        tool = step_tool(site.step)
        if tool is not None and tool not in allowed:
            problems.append(f"step {site.step.id!r}: {tool} is not a tool of this mission ({why or ALLOWED_WHY})")
    return problems


def destination_review(steps: Iterable[Step], config: BuiltinConfig) -> list[str]:
    """A reason for each alert of a model's plan addressed outside the configured allowlists (recipients, webhook
    hosts; :mod:`tools.builtin.allowlist`), so the plan is refused before any of it flies."""
    problems = []
    for site in walk_steps(list(steps)):
        tool, args = step_tool(site.step), getattr(site.step, "args", None)
        data = args.model_dump(mode="json") if isinstance(args, BaseModel) else args
        if tool is not None and isinstance(data, dict):
            problems += [f"step {site.step.id!r}: {p}" for p in destination_problems(config, tool, data)]
    return problems


__all__ = [
    "ALLOWED_WHY",
    "RUN_TOOLS",
    "destination_review",
    "mission_caller",
    "mission_tools",
    "plan_tools",
    "step_tool",
    "tool_problems",
]
