"""Asking a model for a Plan (the contract, ``Proposal``, is in :mod:`agentic_core.contracts.plan`): the steps a
reasoner proposes in answer to an event or a failure, in the mission language.

A proposal is only words until the mission validator has passed it: the steps are the same ``Step`` models a
mission file holds, so the same checks (actions, tools, geofence, altitude) apply to a model's plan as to a
person's.

>>> proposal = Proposal.model_validate({"steps": [{"id": "hold_here", "action": "hover", "args": {"duration_s": 5}}],
...                                     "rationale": "wait for the crowd to clear"})
>>> [s.action for s in proposal.steps]
['hover']
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from agentic_core.contracts.plan import Proposal, proposal_json_schema

from .llm import ChatRequest

if TYPE_CHECKING:
    from .model_reasoners import StructuredChat


def ask(
    client: StructuredChat,
    request: ChatRequest,
    entry: dict[str, Any],
    record: Callable[[dict[str, Any]], None] | None = None,
) -> list[dict[str, Any]] | None:
    """Ask ``client`` for a :class:`Proposal`; report the exchange (``entry`` plus model, status, latency,
    tokens, outcome, rationale, steps) to ``record``; the proposed steps as mission-file data, or None when the
    model failed, refused or proposed nothing."""
    result = client.chat_structured_sync(request, Proposal)
    entry = {
        **entry,
        "model": client.model,
        "status": result.status,
        "latency_s": result.latency_s,
        "tokens": result.usage.prompt_tokens + result.usage.completion_tokens,
    }
    proposal = result.parsed if result.ok and isinstance(result.parsed, Proposal) else None
    steps: list[dict[str, Any]] = []
    if proposal is None:
        entry["outcome"] = f"no proposal: {result.error or result.status}"
    else:
        steps = [s.model_dump(mode="json", by_alias=True, exclude_none=True) for s in proposal.steps]
        entry.update(outcome=f"{len(steps)} step(s) proposed" if steps else "nothing proposed", steps=steps,
                     rationale=proposal.rationale)  # fmt: skip
    if record is not None:
        record(entry)
    return steps or None


def schema_text() -> str:
    """:func:`proposal_json_schema` as the text shipped in ``prompts/schemas/plan.schema.json``."""
    return json.dumps(proposal_json_schema(), indent=2) + "\n"


__all__ = ["Proposal", "ask", "proposal_json_schema", "schema_text"]
