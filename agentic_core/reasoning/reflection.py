"""Reflection by a model: a failed step, its error and the mission's state go to the model with the reflection
prompt; the steps it proposes come back as a :class:`Proposal` for the mission runtime to check and splice in.

The runtime checks a revision exactly like a mission file (actions, tools against the catalogue, expressions,
geofence, altitude) and refuses it otherwise — logged as ``revision rejected`` with the reasons, after which the
mission aborts safely (the aircraft holds). A model that fails, refuses, or proposes nothing gives up the same
way. Every exchange is reported to ``record`` (the run's trace), refusals included.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from typing import Any

import prompts

from ..mission.compile import Failure
from ..mission.model import PolicyGraph
from .llm import ChatRequest, Message
from .model_reasoners import StructuredChat
from .proposal import Proposal


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
            error=failure.error,
            done=", ".join(sorted(k for k, v in status.items() if v == "ok")) or "none",
            attempt=self.attempts,
            max_attempts=self.max_attempts,
        )
        return ChatRequest(messages=[Message.system(prompts.template("system")), Message.user(user)], temperature=0)

    def __call__(self, failure: Failure) -> list[dict[str, Any]] | None:
        self.attempts += 1
        result = self.client.chat_structured_sync(self.request(failure), Proposal)
        entry: dict[str, Any] = {
            "step": failure.step.id,
            "error": failure.error,
            "model": self.client.model,
            "status": result.status,
            "latency_s": result.latency_s,
            "tokens": result.usage.prompt_tokens + result.usage.completion_tokens,
        }
        proposal = result.parsed if result.ok and isinstance(result.parsed, Proposal) else None
        if proposal is None:
            entry["outcome"] = f"no revision: {result.error or result.status}"
        else:
            entry["outcome"] = f"{len(proposal.steps)} step(s) proposed" if proposal.steps else "gave up"
            entry["rationale"] = proposal.rationale
            entry["steps"] = [s.model_dump(mode="json", by_alias=True, exclude_none=True) for s in proposal.steps]
        if self.record is not None:
            self.record(entry)
        if proposal is None or not proposal.steps:
            return None
        steps: list[dict[str, Any]] = entry["steps"]
        return steps


__all__ = ["LLMReflector"]
