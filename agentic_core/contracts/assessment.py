"""Assessment and DecisionRecord: what a reasoner says of a scene, and the timed decision that carries it.

``Assessment`` holds exactly the fields the paper's evaluation records and an LLM is asked for (its JSON Schema is
the structured output the prompts request); ``DecisionRecord`` (also ``Decision``) adds what the framework
measures around it — which reasoner, how long it took, how many model calls and tokens — so every reasoner, from
the YOLO baseline to an LLM, yields the same record.

>>> a = Assessment(persons_detected=1, confidence=0.89, severity="critical",
...                surrounding_features="Individual lying motionless, isolated from pedestrian flow.",
...                recommended_actions=["deploy_rescue_kit", "alert_medical_team"], rationale="collapsed")
>>> a.contextual, a.recommends_action
(True, True)
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

Severity = Literal["none", "low", "high", "critical"]
SEVERITIES: tuple[Severity, ...] = ("none", "low", "high", "critical")
"""In increasing order of urgency."""

CONTEXTUAL_MIN_CHARS = 50
"""The paper's Contextual Analysis Rate counts a ``surrounding_features`` longer than this many characters."""


class Assessment(BaseModel):
    """A reasoner's reading of a scene: how many people, how sure, what surrounds them, how urgent, what to do.

    ``confidence`` is the system's own certainty in [0, 1]: the detector's confidence for the YOLO baseline and the
    rule reasoner, and for an LLM the self-reported score the prompt asks for (as in the paper) — not a
    calibrated probability.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    persons_detected: int = Field(ge=0, description="how many people are in view")
    confidence: float = Field(ge=0.0, le=1.0, description="certainty of this assessment, 0 to 1")
    surrounding_features: str = Field(
        default="", description="what surrounds the people: posture, crowd, landmarks, hazards (free text)"
    )
    severity: Severity = Field(default="none", description="none, low, high or critical")
    recommended_actions: list[str] = Field(
        default_factory=list, description="actions recommended, e.g. deploy_rescue_kit, alert_medical_team"
    )
    rationale: str = Field(default="", description="why this severity and these actions")
    subject_id: str | None = Field(default=None, description="the world-model object the assessment is about")

    @property
    def contextual(self) -> bool:
        """Counts towards the paper's Contextual Analysis Rate (``surrounding_features`` over 50 characters)."""
        return len(self.surrounding_features.strip()) > CONTEXTUAL_MIN_CHARS

    @property
    def recommends_action(self) -> bool:
        """Counts towards the paper's Action Recommendation Rate (at least one recommended action)."""
        return bool(self.recommended_actions)

    def at_least(self, severity: Severity) -> bool:
        return SEVERITIES.index(self.severity) >= SEVERITIES.index(severity)


class DecisionRecord(BaseModel):
    """One assessment as the framework recorded it: the reasoner, its timing and what it cost.

    ``assessment`` is ``None`` when the reasoner failed (``error`` says why): a failing model is a result the agent
    and the evaluation see, never a crash.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    reasoner: str = Field(description="yolo, rules, llm:<model> or hybrid")
    assessment: Assessment | None
    processing_time_s: float = Field(ge=0.0, description="wall time of the whole assessment, model calls included")
    model_time_s: float = Field(
        default=0.0,
        ge=0.0,
        description="of which the model's own time: what its server says it spent when it says so (OpenAI's "
        "openai-processing-ms, Ollama's total_duration), else the whole wait for its answer",
    )
    llm_calls: int = Field(default=0, ge=0)
    prompt_tokens: int = Field(default=0, ge=0)
    completion_tokens: int = Field(default=0, ge=0)
    cached: bool = Field(default=False, description="answered from an identical earlier situation (hybrid)")
    escalated: bool = Field(default=False, description="the hybrid reasoner consulted its model")
    error: str | None = None

    @property
    def ok(self) -> bool:
        return self.assessment is not None


Decision = DecisionRecord
"""The record's older name."""


def decision_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`DecisionRecord`."""
    return DecisionRecord.model_json_schema()


def assessment_json_schema() -> dict[str, Any]:
    """The JSON Schema of :class:`Assessment` (the structured output the prompts ask a model for)."""
    return Assessment.model_json_schema()


__all__ = [
    "CONTEXTUAL_MIN_CHARS",
    "SEVERITIES",
    "Assessment",
    "Decision",
    "DecisionRecord",
    "Severity",
    "assessment_json_schema",
    "decision_json_schema",
]
