"""Choosing a reasoner by name (``--reasoner yolo|rules|llm|hybrid``): the one pluggable part of the agent.

Every reasoner answers ``assess(world, focus) -> Decision`` with the same :class:`Assessment` record, timed, so
everything around it is identical for all four and the evaluation compares like with like.

>>> make_reasoner("rules").name, make_reasoner("yolo").name
('rules', 'yolo')
>>> make_reasoner("llm")
Traceback (most recent call last):
...
agentic_core.reasoning.reasoners.ReasonerError: --reasoner llm needs a model: --llm SPEC or AGENTIC_UAV_LLM ...
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Protocol

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.world_model import WorldModel

from .assessment import Decision
from .llm import LLMSpecError, create_client
from .model_reasoners import HybridReasoner, LLMReasoner, StructuredChat
from .rules import RuleReasoner, RuleSettings, YoloBaseline

REASONERS = ("yolo", "rules", "llm", "hybrid")


class Reasoner(Protocol):
    """Reads a World Model (about one object, if ``focus`` names it) and says what it makes of it."""

    name: str

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision: ...


class ReasonerError(InputError):
    """An unknown reasoner, or one that needs a model and has none: a usage error (exit status 2)."""


def make_reasoner(
    kind: str,
    *,
    llm: str | None = None,
    client: StructuredChat | None = None,
    goal: str = "",
    rules: RuleSettings | None = None,
    environ: Mapping[str, str] | None = None,
) -> Reasoner:
    """The reasoner called ``kind``; ``llm`` and ``hybrid`` use ``client``, or one made from the ``llm`` spec (or
    ``AGENTIC_UAV_LLM``)."""
    if kind == "yolo":
        return YoloBaseline()
    if kind == "rules":
        return RuleReasoner(rules)
    if kind not in ("llm", "hybrid"):
        raise ReasonerError(f"unknown reasoner {kind!r}; choose one of: {', '.join(REASONERS)}")
    env = os.environ if environ is None else environ
    if client is None:
        spec = llm or env.get("AGENTIC_UAV_LLM")
        if not spec:
            raise ReasonerError(f"--reasoner {kind} needs a model: --llm SPEC or AGENTIC_UAV_LLM (e.g. openai:gpt-4o)")
        try:
            client = create_client(spec, environ=env)
        except LLMSpecError as exc:
            raise ReasonerError(str(exc)) from None
    model = LLMReasoner(client, goal=goal)
    return model if kind == "llm" else HybridReasoner(RuleReasoner(rules), model)


__all__ = ["REASONERS", "Reasoner", "ReasonerError", "make_reasoner"]
