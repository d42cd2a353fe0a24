"""The response plan a model writes for an event: the planning prompt in, a :class:`~.proposal.Proposal` out.

A trigger marked ``plan: reasoner`` asks for one when it fires (after the assessment let it act). The steps come
back as mission-file data; the mission runtime checks them exactly like a mission file (actions, tools, limits,
geofence) plus the runner's review (scopes, approvals), and runs the trigger's own steps instead when they are
refused, empty, or the model fails. Every exchange goes to ``record`` (the run's trace).

>>> "call_tool may call" in actions_text([Tool("incidents.log", "Log an incident.", {"properties": {"kind": {}}})])
True
"""

from __future__ import annotations

import json
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import prompts
from agentic_core.contracts.policy_graph import ACTION_TOOLS, PolicyGraph

from .assessment import Assessment
from .llm import ChatRequest, Message
from .model_reasoners import StructuredChat
from .proposal import ask

CONTROL_ACTIONS = ("call_tool", "wait_until", "repeat", "branch")


class DescribedTool(Protocol):
    """What the prompt shows of a tool (``tools.ToolRegistry.describe`` gives one)."""

    @property
    def name(self) -> str: ...
    @property
    def description(self) -> str: ...
    @property
    def input_schema(self) -> Mapping[str, Any]: ...


@dataclass(frozen=True)
class Tool:
    """A tool as the prompt shows it, for callers without a registry."""

    name: str
    description: str
    input_schema: Mapping[str, Any]


def actions_text(tools: Iterable[DescribedTool]) -> str:
    """The actions a plan may use, and the tools ``call_tool`` may call (those no action stands for)."""
    lines = [f"Actions (their arguments are in the output schema): {', '.join([*ACTION_TOOLS, *CONTROL_ACTIONS])}."]
    behind_actions = set(ACTION_TOOLS.values())
    extra = [t for t in tools if t.name not in behind_actions]
    if extra:
        lines.append("call_tool may call these tools (tool: name, args: an object):")
        for tool in sorted(extra, key=lambda t: t.name):
            properties = tool.input_schema.get("properties") or {}
            required = set(tool.input_schema.get("required") or [])
            args = ", ".join(f"{name}{'' if name in required else '?'}" for name in properties)
            summary = (tool.description or "").strip().splitlines()[0] if tool.description else ""
            lines.append(f"- {tool.name}({args}): {summary}")
    return "\n".join(lines)


def _json(value: Any) -> str:
    data = value.model_dump(mode="json") if hasattr(value, "model_dump") else value
    return json.dumps(data, ensure_ascii=False, default=str)


class LLMPlanner:
    """The model's plan for an event (``planner(assessment, event)`` → steps or None)."""

    def __init__(
        self,
        client: StructuredChat,
        plan: PolicyGraph,
        tools: Iterable[DescribedTool] = (),
        *,
        record: Callable[[dict[str, Any]], None] | None = None,
    ) -> None:
        self.client = client
        self.plan = plan
        self.actions = actions_text(tools)
        self.record = record

    def request(self, assessment: Assessment | None, event: Any) -> ChatRequest:
        """The chat request for one plan (public so a trace can show exactly what was asked)."""
        limits = self.plan.limits.model_dump(mode="json", exclude_none=True)
        user = prompts.render(
            "plan",
            goal=self.plan.goal,
            limits=json.dumps(limits, ensure_ascii=False),
            assessment=assessment.model_dump_json() if assessment is not None else "none (the reasoner failed)",
            event=_json(event),
            actions=self.actions,
        )
        return ChatRequest(messages=[Message.system(prompts.template("system")), Message.user(user)], temperature=0)

    def __call__(self, assessment: Assessment | None, event: Any) -> list[dict[str, Any]] | None:
        subject = assessment.subject_id if assessment is not None else None
        return ask(self.client, self.request(assessment, event), {"event": subject}, self.record)


__all__ = ["CONTROL_ACTIONS", "DescribedTool", "LLMPlanner", "Tool", "actions_text"]
