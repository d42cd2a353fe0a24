"""Reflection by a model: a failed step, its error and the mission's state go to the model with the reflection
prompt; the steps it proposes come back as a :class:`Proposal` for the mission runtime to check and splice in.

The runtime checks a revision exactly like a mission file (actions, tools against the catalogue, expressions,
geofence, altitude) and refuses it otherwise — logged as ``revision rejected`` with the reasons, after which the
mission aborts safely (the aircraft holds). A model that fails, refuses, or proposes nothing gives up the same
way. Every exchange is reported to ``record`` (the run's trace), refusals included. The error text comes from a
tool, so it reaches the prompt fenced by the injection guard (``tools.security.wrap_untrusted``).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any

import prompts
from agentic_core.contracts.failure import Failure
from agentic_core.contracts.policy_graph import PolicyGraph
from tools.security import wrap_untrusted

from .llm import ChatRequest, Message
from .model_reasoners import StructuredChat
from .proposal import ask


class LLMReflector:
    """The mission's reflector (``compile_mission(..., reflector=LLMReflector(client, plan))``)."""

    def __init__(
        self,
        client: StructuredChat,
        plan: PolicyGraph,
        *,
        max_attempts: int = 3,
        record: Callable[[dict[str, Any]], None] | None = None,
    ) -> None:
        self.client = client
        self.plan = plan
        self.max_attempts = max_attempts
        self.record = record
        self.attempts = 0

    def request(self, failure: Failure) -> ChatRequest:
        """The chat request for one reflection (public so a trace can show exactly what was asked)."""
        status: Mapping[str, str] = failure.state.get("status") or {}
        limits = self.plan.limits.model_dump(mode="json", exclude_none=True) if self.plan.limits else {}
        user = prompts.render(
            "reflect",
            goal=self.plan.goal,
            limits=json.dumps(limits, ensure_ascii=False),
            step=failure.step.model_dump_json(by_alias=True, exclude_none=True),
            error=wrap_untrusted(failure.error, source=f"the error of step {failure.step.id}"),
            done=", ".join(sorted(k for k, v in status.items() if v == "ok")) or "none",
            attempt=self.attempts,
            max_attempts=self.max_attempts,
        )
        return ChatRequest(messages=[Message.system(prompts.template("system")), Message.user(user)], temperature=0)

    def __call__(self, failure: Failure) -> list[dict[str, Any]] | None:
        self.attempts += 1
        return ask(self.client, self.request(failure), {"step": failure.step.id, "error": failure.error}, self.record)


__all__ = ["LLMReflector"]
