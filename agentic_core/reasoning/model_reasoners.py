"""The reasoners that consult a language model: ``llm`` (every assessment) and ``hybrid`` (rules first).

``llm`` renders the World Model into the assessment prompt and asks the model for an :class:`Assessment` as
structured output; a model that fails (timeout, refusal, output that breaks the schema twice) gives a failed
:class:`Decision` with the reason, which the agent handles like any failed tool.

``hybrid`` is the paper's recommended design: the rule reasoner (tier 1) reads every frame, and only a critical
event — its severity ``high`` or worse — is put to the model (tier 2); an identical situation (the same subject
at the same rule severity) is not asked twice, its earlier answer is reused. :attr:`HybridReasoner.saved` counts
the model calls this avoided.

The World Model can hold a thousand people; the prompt carries at most ``max_objects`` of them, the subject and the
people motionless or isolated first, then the nearest to the subject, and says how many it left out.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Sequence
from typing import Any, Protocol

from pydantic import BaseModel

import prompts
from agentic_core.contracts.memory import RecallPort, Recollection
from agentic_core.contracts.world_model import WorldModel, WorldObject

from .assessment import Assessment, Decision, Severity
from .examples import examples_block
from .knowledge import cite_knowledge, knowledge_block
from .llm import ChatRequest, LLMResult, Message
from .rules import RuleReasoner


class StructuredChat(Protocol):
    """What the model reasoners and the reflector need of an LLM client (every client in
    :mod:`agentic_core.reasoning.llm` has it): structured output into a pydantic model."""

    @property
    def model(self) -> str: ...

    def chat_structured_sync(self, request: ChatRequest, output: type[BaseModel]) -> LLMResult: ...


def world_model_prompt(world: WorldModel, focus: str | None = None, max_objects: int = 40) -> str:
    """The World Model as compact JSON for a prompt: at most ``max_objects`` objects, the most telling first."""
    objects = world.objects
    if len(objects) <= max_objects:
        return world.to_json()
    subject = world.get(focus) if focus else None
    cx, cy = (subject.pose.north, subject.pose.east) if subject else (world.ego_pose.north, world.ego_pose.east)
    flagged = {r.subj for r in world.relations if r.pred in ("isolated_from", "stationary")}

    def priority(o: WorldObject) -> tuple[int, int, float]:
        return (o.id != focus, o.id not in flagged, math.hypot(o.pose.north - cx, o.pose.east - cy))

    kept = {o.id for o in sorted(objects, key=priority)[:max_objects]}
    shown = world.model_copy(
        update={
            "objects": [o for o in objects if o.id in kept],
            "relations": [r for r in world.relations if r.subj in kept],
        }
    )
    text = shown.to_json()  # pydantic's own serialiser: compact JSON, several times quicker than json.dumps
    return f'{text[:-1]},"omitted_objects":{len(objects) - len(kept)}}}'


class LLMReasoner:
    """Every assessment by the model: the system and assessment prompts, an :class:`Assessment` back."""

    def __init__(
        self, client: StructuredChat, *, goal: str = "", max_objects: int = 40, temperature: float | None = 0.0
    ) -> None:
        self.client = client
        self.goal = goal
        self.max_objects = max_objects
        self.temperature = temperature
        self.name = f"llm:{client.model}"
        self.knowledge: RecallPort | None = None
        """The knowledge port (a mission's ``knowledge:``): passages for the prompt, fenced as untrusted data."""
        self.examples: RecallPort | None = None
        """Past operator answers about similar evidence (``--memory``): few-shot examples, fenced the same way."""

    def passages(self, world: WorldModel, focus: str | None = None) -> list[Recollection]:
        """The knowledge passages for this assessment (none without a port, or when it fails: a knowledge base that
        cannot be read must not cost the decision)."""
        return _read(self.knowledge, world, focus)

    def request(
        self, world: WorldModel, focus: str | None = None, passages: Sequence[Recollection] = ()
    ) -> ChatRequest:
        """The chat request for one assessment (public so a trace can show exactly what was asked)."""
        return self._request(world, focus, knowledge_block(passages)[0])

    def _request(self, world: WorldModel, focus: str | None, knowledge: str) -> ChatRequest:
        """The chat request with the knowledge section already screened and fenced (:func:`knowledge_block`)."""
        ego = world.ego_pose
        user = prompts.render(
            "assess",
            goal=self.goal or "patrol and assist anyone in need",
            time_s=f"{world.timestamp:.1f}",
            ego=f"lat {ego.lat:.6f}, lon {ego.lon:.6f}, {-ego.down:.0f} m above home",
            focus_line=f"Focus on object {focus}.\n" if focus else "",
            world_model=world_model_prompt(world, focus, self.max_objects),
            knowledge=knowledge,
        )
        return ChatRequest(
            messages=[Message.system(prompts.template("system")), Message.user(user)], temperature=self.temperature
        )

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        start = time.perf_counter()
        passages = self.passages(world, focus)
        knowledge, used, kept_out = knowledge_block(passages)  # each passage screened once, for prompt and citation
        shots, shown, screened = examples_block(_read(self.examples, world, focus))
        result = self.client.chat_structured_sync(self._request(world, focus, knowledge + shots), Assessment)
        decision = self._decision(result, time.perf_counter() - start)
        if (used or kept_out or shown or screened) and decision.assessment is not None:
            cited = cite_knowledge(decision.assessment, used + shown, kept_out + screened)
            decision = decision.model_copy(update={"assessment": cited})
        return decision

    def _decision(self, result: LLMResult, elapsed: float) -> Decision:
        common: dict[str, Any] = {
            "reasoner": self.name,
            "processing_time_s": elapsed,
            "model_time_s": min(result.latency_s if result.server_s is None else result.server_s, elapsed),
            "llm_calls": 1,
            "prompt_tokens": result.usage.prompt_tokens,
            "completion_tokens": result.usage.completion_tokens,
            "escalated": True,
        }
        if result.ok and isinstance(result.parsed, Assessment):
            return Decision(assessment=result.parsed, **common)
        return Decision(assessment=None, error=f"{result.status}: {result.error or 'no assessment'}", **common)


def _read(port: RecallPort | None, world: WorldModel, focus: str | None) -> list[Recollection]:
    """What a context port gives (nothing without one, or when it fails: a memory must not cost the decision)."""
    if port is None:
        return []
    try:
        return list(port(world, focus))
    except Exception:
        return []


DEADLINE_S = 10.0
"""How long the hybrid reasoner waits for its model before its rules' reading stands (a slow local model can take
40 s; a casualty must not wait that long)."""


class HybridReasoner:
    """Rules on every frame; the model only on critical events, never twice for the same situation, and never for
    longer than ``deadline_s``: past it the rules' assessment stands, and the decision says so."""

    name = "hybrid"

    def __init__(
        self,
        rules: RuleReasoner,
        model: LLMReasoner,
        *,
        escalate_at: Severity = "high",
        deadline_s: float | None = DEADLINE_S,
    ) -> None:
        if deadline_s is not None and not deadline_s > 0:
            raise ValueError("deadline_s must be positive (or None: wait as long as the model takes)")
        self.rules = rules
        self.model = model
        self.escalate_at = escalate_at
        self.deadline_s = deadline_s
        self.consulted = 0
        """Model calls made."""
        self.saved = 0
        """Assessments that would have been a model call in the ``llm`` design: rule-only ones and reused ones."""
        self._answers: dict[tuple[str | None, str], Decision] = {}

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        start = time.perf_counter()
        tier1 = self.rules.assess(world, focus)
        if tier1.assessment is None or not tier1.assessment.at_least(self.escalate_at):
            self.saved += 1
            return tier1.model_copy(update={"reasoner": self.name})
        key = (tier1.assessment.subject_id, tier1.assessment.severity)
        earlier = self._answers.get(key)
        if earlier is not None:
            self.saved += 1
            return earlier.model_copy(
                update={
                    "processing_time_s": time.perf_counter() - start,
                    "cached": True,
                    "model_time_s": 0.0,
                    "llm_calls": 0,
                    "prompt_tokens": 0,
                    "completion_tokens": 0,
                }
            )
        decision = self._ask(world, focus or tier1.assessment.subject_id, start)
        self.consulted += 1
        decision = decision.model_copy(
            update={"reasoner": self.name, "processing_time_s": time.perf_counter() - start, "escalated": True}
        )
        if decision.ok:
            self._answers[key] = decision
            return decision
        # The model failed or was too slow: the rules' own reading stands, and why is kept on the record.
        return tier1.model_copy(
            update={
                "reasoner": self.name,
                "processing_time_s": decision.processing_time_s,
                "model_time_s": decision.model_time_s,
                "llm_calls": decision.llm_calls,
                "prompt_tokens": decision.prompt_tokens,
                "completion_tokens": decision.completion_tokens,
                "escalated": True,
                "error": f"model failed, rules' assessment kept: {decision.error}",
            }
        )

    def _ask(self, world: WorldModel, focus: str | None, start: float) -> Decision:
        """The model's decision, or a failed one when it has not answered within the deadline (its call goes on in
        the background, and its late answer is dropped)."""
        if self.deadline_s is None:
            return self.model.assess(world, focus)
        box: dict[str, Decision] = {}
        worker = threading.Thread(
            target=lambda: box.setdefault("decision", self.model.assess(world, focus)), name="hybrid-model", daemon=True
        )
        worker.start()
        worker.join(self.deadline_s)
        if "decision" in box:
            return box["decision"]
        waited = time.perf_counter() - start
        return Decision(
            reasoner=self.name, assessment=None, processing_time_s=waited, model_time_s=waited, llm_calls=1,
            error=f"no answer within the {self.deadline_s:g} s deadline",
        )  # fmt: skip


def model_of(reasoner: object) -> LLMReasoner | None:
    """The language-model reasoner inside ``reasoner`` (itself, or a hybrid's tier 2); None for rules alone."""
    if isinstance(reasoner, LLMReasoner):
        return reasoner
    inner = getattr(reasoner, "model", None)
    return inner if isinstance(inner, LLMReasoner) else None


__all__ = ["DEADLINE_S", "HybridReasoner", "LLMReasoner", "StructuredChat", "model_of", "world_model_prompt"]
