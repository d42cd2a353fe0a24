"""Operator feedback as data: what the operator saw (:class:`PreferenceFeatures`), what they answered
(:class:`Preference`), and the port through which the fitted answers reach the rules (:class:`ThresholdPort`).

Features are bounded: a record claiming a confidence of 7 or a person still for a year is refused, naming the field.

>>> from agentic_core.contracts.world_model import WorldModel
>>> world = WorldModel.model_validate({"timestamp": 20.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
...     "lat": 21.4133, "lon": 39.8933, "alt": 30}, "objects": [{"id": "P-7", "class": "person", "conf": 0.9,
...     "stationary_s": 14.0, "pose": {"north": 40, "east": 5, "down": 0, "lat": 21.41366, "lon": 39.89335, "alt": 0}}],
...     "relations": [{"subj": "P-7", "pred": "isolated_from", "obj": "crowd", "value": 31.0}]})
>>> f = PreferenceFeatures.of(world, "P-7", severity="critical")
>>> f.stationary_s, f.isolation_m, f.severity
(14.0, 31.0, 'critical')
>>> PreferenceFeatures(object_class="person", severity="high", confidence=7.0, stationary_s=3.0)
Traceback (most recent call last):
...
pydantic_core._pydantic_core.ValidationError: 1 validation error for PreferenceFeatures
confidence
...
"""

from __future__ import annotations

from typing import Literal, Protocol

from pydantic import BaseModel, ConfigDict, Field

from .assessment import Severity
from .world_model import WorldModel

MAX_STILL_S = 6 * 3600.0
"""Longer than any flight: a stillness beyond it is not evidence but a broken record."""
MAX_ISOLATION_M = 5000.0
Verdict = Literal["approved", "declined", "edited"]


class PreferenceFeatures(BaseModel):
    """The evidence an operator's answer was about: the subject's class, the assessed severity, and the numbers the
    rules grade on (confidence, seconds motionless, metres from the crowd)."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    object_class: str = Field(default="person", pattern=r"^[a-z][a-z_]{0,31}$")
    severity: Severity = "none"
    confidence: float = Field(default=0.0, ge=0.0, le=1.0)
    stationary_s: float = Field(default=0.0, ge=0.0, le=MAX_STILL_S)
    isolation_m: float | None = Field(default=None, ge=0.0, le=MAX_ISOLATION_M)

    @classmethod
    def of(cls, world: WorldModel, object_id: str, *, severity: Severity = "none") -> PreferenceFeatures | None:
        """The features of one object of a World Model (None when it is not there)."""
        obj = world.get(object_id)
        if obj is None:
            return None
        isolation = next((r.value for r in world.relations_of(object_id) if r.pred == "isolated_from"), None)
        return cls(object_class=obj.class_name, severity=severity, confidence=obj.conf,
                   stationary_s=min(obj.stationary_s, MAX_STILL_S),
                   isolation_m=None if isolation is None else min(max(isolation, 0.0), MAX_ISOLATION_M))  # fmt: skip


class Preference(BaseModel):
    """One operator answer with its provenance: approved, declined, or approved with edited arguments."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    verdict: Verdict
    action: str = Field(default="", max_length=200)
    step: str | None = Field(default=None, max_length=200)
    object_id: str | None = Field(default=None, max_length=100)
    features: PreferenceFeatures
    said: str = Field(default="", max_length=2000, description="what the operator said (untrusted text)")
    run_id: str | None = None
    seq: int | None = None

    @property
    def approved(self) -> bool:
        """An edit approves the action (with other arguments)."""
        return self.verdict != "declined"


class ThresholdPort(Protocol):
    """The rules' prior from operator feedback: seconds to add to the stillness threshold for this evidence
    (negative: the operators act sooner than the rules)."""

    def __call__(self, features: PreferenceFeatures, /) -> float: ...


__all__ = ["MAX_ISOLATION_M", "MAX_STILL_S", "Preference", "PreferenceFeatures", "ThresholdPort", "Verdict"]
