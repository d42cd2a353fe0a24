"""The model's other jobs in a run (llm and hybrid reasoners): writing the response plan for a trigger marked
``plan: reasoner`` and reflecting on a failed step — both published as events, both paced as model waits."""

from __future__ import annotations

import contextlib
from typing import Any

from tools import Caller, ToolRegistry

from ..agent.gate import Gate
from ..agent.pacing import Pace
from ..agent.ports import Publish
from ..mission.compile import Reflector, abort_reflector
from ..mission.model import PolicyGraph, Trigger
from ..mission.triggers import object_id
from ..reasoning.model_reasoners import StructuredChat
from ..reasoning.planning import LLMPlanner
from ..reasoning.reasoners import Reasoner
from ..reasoning.reflection import LLMReflector
from .privilege import plan_tools
from .settings import AGENT
from .untrusted_reads import UntrustedReads


def model_client(reasoner: Reasoner) -> StructuredChat | None:
    """The model client an llm or hybrid reasoner asks (None for yolo and rules)."""
    client: StructuredChat | None = getattr(reasoner, "client", None) or getattr(
        getattr(reasoner, "model", None), "client", None
    )
    return client


def close_client(client: object) -> None:
    """Close a model client's connections and event-loop thread, if it has a ``close``. Best effort: a model
    call still hanging when the run ends must not keep the run from closing the rest."""
    close = getattr(client, "close", None)
    if callable(close):
        with contextlib.suppress(Exception):
            close()


class ModelSide:
    """The reasoner's model client (None for yolo and rules) as planner and reflector of one run."""

    def __init__(
        self,
        reasoner: Reasoner,
        plan: PolicyGraph,
        registry: ToolRegistry,
        gate: Gate,
        publish: Publish,
        pace: Pace,
        *,
        caller: Caller = AGENT,
    ) -> None:
        self.mission = plan
        self.gate = gate
        self.publish = publish
        self.pace = pace
        self.client = model_client(reasoner)
        self.reads = UntrustedReads(publish)  # once the model reads untrusted text, only the mission's tools
        self.planner = (
            LLMPlanner(
                self.reads.watch(self.client, "plan"), plan, _tools_for_plans(registry, caller, plan_tools(plan)),
                record=self._exchange("plan"),
            )
            if self.client is not None
            else None
        )  # fmt: skip

    def reflector(self) -> Reflector:
        """A model's reflection when the reasoner has a model (llm, hybrid); else the default, which aborts."""
        if self.client is None:
            return abort_reflector
        reflect = LLMReflector(self.reads.watch(self.client, "reflection"), self.mission,
                               record=self._exchange("reflection"))  # fmt: skip

        def paced(failure: Any) -> Any:
            with self.pace.waiting("model"):
                return reflect(failure)

        return paced

    def plan(self, trigger: Trigger, event: Any) -> list[dict[str, Any]] | None:
        """The model's response plan for an event a trigger fired on (``plan: reasoner``); the mission checks it."""
        assert self.planner is not None
        assessment = self.gate.assessment(trigger.id, event)
        self.publish("log", level="info", summary=f"planning the response to {trigger.id} on {object_id(event)}")
        with self.pace.waiting("model"):
            return self.planner(assessment, event)

    def _exchange(self, kind: str) -> Any:
        def record(entry: dict[str, Any]) -> None:
            self.publish(kind, **entry, summary=f"{kind} by {entry.get('model')}: {entry.get('outcome')}")

        return record


def _tools_for_plans(registry: ToolRegistry, caller: Caller, allowed: frozenset[str]) -> list[Any]:
    """The tools a model's plan may name: the mission's own (and ``allow_tools``) the agent holds every scope of."""
    return [
        registry.describe(n) for n in registry.names() if n in allowed and not caller.missing(registry.get(n).scopes)
    ]


__all__ = ["ModelSide"]
