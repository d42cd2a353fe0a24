"""Whether the run's model answers, asked once before anything flies: ``--reasoner llm`` cannot fly without it
(:class:`~agentic_core.run.settings.RunError`, exit 2, naming the URL and the fix); ``hybrid`` flies on its rules
alone and says so once (the returned note goes to the trace and the report). Rules and yolo need no model.

>>> from agentic_core.reasoning.rules import RuleReasoner
>>> rules = RuleReasoner()
>>> require_model(rules) == (rules, None)
True
"""

from __future__ import annotations

from typing import Any

from ..reasoning.model_reasoners import HybridReasoner
from ..reasoning.reasoners import Reasoner
from .settings import RunError

FIX = (
    "start the model server, or give another with --llm SPEC (or AGENTIC_UAV_LLM); "
    "--reasoner rules flies without a model, and --reasoner hybrid flies on its rules alone when the model is down"
)


def model_client(reasoner: Reasoner) -> Any:
    """The reasoner's model client: its own (llm) or its model's (hybrid); None without a model."""
    return getattr(reasoner, "client", None) or getattr(getattr(reasoner, "model", None), "client", None)


def require_model(reasoner: Reasoner) -> tuple[Reasoner, str | None]:
    """The reasoner to fly with and what to say about it: the reasoner itself when its model answers (or it has
    none); for a hybrid whose model does not answer, its rules alone and a note saying so; for ``llm``, a
    :class:`RunError`."""
    client = model_client(reasoner)
    warm = getattr(client, "warm", None)
    if not callable(warm):
        return reasoner, None
    problem = warm()
    if problem is None:
        return reasoner, None
    url = f"{client.base_url}{getattr(client, 'probe_endpoint', '')}"
    if not isinstance(reasoner, HybridReasoner):
        raise RunError(f"--reasoner llm: the model at {url} does not answer ({problem}); nothing was flown. {FIX}")
    note = (
        f"The model at {url} did not answer before take-off ({problem}): the hybrid reasoner flew on its rules "
        "alone; no model was asked to assess, plan or reflect."
    )
    return reasoner.rules, note


__all__ = ["FIX", "model_client", "require_model"]
