"""The two reasoners that need no model: the paper's YOLO baseline and a deterministic expert (``rules``).

``yolo`` reports what the detector saw — how many people, how confident — and nothing more: no scene
description, no severity, no action (the paper's baseline). ``rules`` reads the World Model the way a trained
observer would, by a fixed table:

========  ===============================================================================  ==========================
severity  when                                                                             recommended actions
========  ===============================================================================  ==========================
critical  a person motionless for ``still_s`` or more, isolated from the crowd, and not    land_nearby,
          resting at a shelter (tent, shade, medical post within ``shelter_radius_m``)     deploy_rescue_kit,
                                                                                           alert_medical_team
high      such a person motionless for ``suspect_s`` or more (not yet ``still_s``)          approach_and_confirm
low       such a person at a shelter (resting), or a crowd denser than ``dense_per_m2``    log_observation /
                                                                                           log_crowd_density
none      people moving normally                                                           log_crowd_density
none      nobody in view                                                                   continue_patrol
========  ===============================================================================  ==========================

Confirmed tracks count, and lost ones too (a person who stops being detected for a few frames — lying still, in a
crowd's shadow — has not gone away; perception drops a lost track when it is stale). The subject is the most urgent
person (then the longest motionless). ``confidence`` is that person's track confidence, or the people's mean, the
detector's own numbers (no self-report).

>>> from agentic_core.perception.world_model import WorldModel
>>> world = WorldModel.model_validate({"timestamp": 20.0, "ego_pose": {"north": 0, "east": 0, "down": -30,
...     "lat": 21.4133, "lon": 39.8933, "alt": 30},
...     "objects": [{"id": "P-7", "class": "person", "conf": 0.89, "stationary_s": 14.0,
...                  "pose": {"north": 40, "east": 5, "down": 0, "lat": 21.41366, "lon": 39.89335, "alt": 0}}],
...     "relations": [{"subj": "P-7", "pred": "isolated_from", "obj": "crowd", "value": 31.0}]})
>>> a = RuleReasoner().assess(world).assessment
>>> a.severity, a.subject_id, a.recommended_actions
('critical', 'P-7', ['land_nearby', 'deploy_rescue_kit', 'alert_medical_team'])
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.spatial import cKDTree

from agentic_core.contracts.feedback import PreferenceFeatures, ThresholdPort
from agentic_core.contracts.world_model import Landmark, WorldModel, WorldObject

from .assessment import SEVERITIES, Assessment, Decision, Severity

CRITICAL_ACTIONS = ["land_nearby", "deploy_rescue_kit", "alert_medical_team"]


class RuleSettings(BaseModel):
    """The rule reasoner's thresholds (the mission's ``still_s`` parameter should match ``still_s``)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    still_s: float = Field(default=10.0, gt=0, description="seconds motionless before a person counts as collapsed")
    suspect_s: float = Field(default=2.0, gt=0, description="seconds motionless before a person is worth a look")
    shelter_kinds: frozenset[str] = frozenset({"tent", "shade", "medical_post"})
    shelter_radius_m: float = Field(default=12.0, gt=0, description="how close to a shelter counts as resting there")
    dense_per_m2: float = Field(default=2.0, gt=0, description="crowd density above which the crowd is noted")
    density_radius_m: float = Field(default=5.0, gt=0, description="radius over which local density is measured")


def timed(reasoner: str, assess: Callable[[], Assessment], clock: Callable[[], float] = time.perf_counter) -> Decision:
    """Run one assessment and wrap it as a :class:`Decision` with its wall time; a failure becomes the error."""
    start = clock()
    try:
        assessment = assess()
    except Exception as exc:  # a reasoner's bug is a failed decision the agent sees, not a crash
        return Decision(
            reasoner=reasoner, assessment=None, processing_time_s=clock() - start, error=f"{type(exc).__name__}: {exc}"
        )
    return Decision(reasoner=reasoner, assessment=assessment, processing_time_s=clock() - start)


def persons(world: WorldModel) -> list[WorldObject]:
    """The people perception is sure of: confirmed tracks, and lost ones not yet dropped."""
    return world.objects_of("person", states=("confirmed", "lost"))


def mean_confidence(people: list[WorldObject]) -> float:
    return sum(p.conf for p in people) / len(people) if people else 0.0


class YoloBaseline:
    """The paper's baseline: detections only — a count and the detector's confidence; no context, no action."""

    name = "yolo"

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        def run() -> Assessment:
            people = persons(world)
            return Assessment(persons_detected=len(people), confidence=mean_confidence(people))

        return timed(self.name, run)


class RuleReasoner:
    """A deterministic expert: the severity table in this module's docstring, with a written scene description."""

    name = "rules"

    def __init__(self, settings: RuleSettings | None = None) -> None:
        self.settings = settings or RuleSettings()
        self.prior: ThresholdPort | None = None
        """Operator feedback as a prior: seconds added to ``still_s`` for a person's evidence (``--memory``)."""

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        return timed(self.name, lambda: self.assessment(world, focus))

    def assessment(self, world: WorldModel, focus: str | None = None) -> Assessment:
        s = self.settings
        people = persons(world)
        if focus is not None:
            focused = world.get(focus)
            if focused is not None and focused not in people and focused.class_name == "person":
                people.append(focused)
        if not people:
            return Assessment(
                persons_detected=0,
                confidence=0.0,
                surrounding_features=self._landmarks_text(world, 0.0, 0.0) or "No people in view.",
                severity="none",
                recommended_actions=["continue_patrol"],
                rationale="Nobody in view.",
            )
        isolated = {r.subj for r in world.relations if r.pred == "isolated_from"}  # once, not per person
        graded = sorted(
            ((self._grade(world, p, p.id in isolated), p) for p in people),
            key=lambda g: (-_rank(g[0][0]), -g[1].stationary_s),
        )
        (severity, actions, why), subject = graded[0]
        if focus is not None:
            chosen = next((g for g in graded if g[1].id == focus), None)
            if chosen is not None:
                (severity, actions, why), subject = chosen
        density = self._density(people)
        if severity == "none" and density > s.dense_per_m2:
            severity, actions, why = "low", ["log_crowd_density"], f"the crowd is dense ({density:.1f} persons/m²)"
        concerned = severity != "none"
        return Assessment(
            persons_detected=len(people),
            confidence=subject.conf if concerned else mean_confidence(people),
            surrounding_features=self._describe(world, people, subject if concerned else None, density),
            severity=severity,
            recommended_actions=actions,
            rationale=why[0].upper() + why[1:] + ".",
            subject_id=subject.id if concerned else None,
        )

    # ---- the table ----

    def _grade(self, world: WorldModel, person: WorldObject, isolated: bool) -> tuple[Severity, list[str], str]:
        s = self.settings
        if isolated and person.stationary_s >= min(s.suspect_s, s.still_s):
            shelter = self._shelter(world, person)
            if shelter is not None:
                return "low", ["log_observation"], f"{person.id} is resting at {shelter.kind} {shelter.id}"
            still_s, moved = self._still_s(world, person)
            if person.stationary_s >= still_s:
                return (
                    "critical",
                    list(CRITICAL_ACTIONS),
                    f"{person.id} has been motionless for {person.stationary_s:.0f} s, isolated from the crowd{moved}",
                )
            return "high", ["approach_and_confirm"], f"{person.id} has stopped moving, isolated from the crowd{moved}"
        return "none", ["log_crowd_density"], "people are moving normally"

    def _still_s(self, world: WorldModel, person: WorldObject) -> tuple[float, str]:
        """The stillness threshold for this person, moved by the operators' answers (and the rationale's note)."""
        s = self.settings
        if self.prior is None:
            return s.still_s, ""
        try:
            features = PreferenceFeatures.of(world, person.id, severity="critical")
            shift = float(self.prior(features)) if features is not None else 0.0
        except Exception:  # a prior that fails must not cost the decision: the table stands
            return s.still_s, ""
        if not math.isfinite(shift) or abs(shift) < 0.05:
            return s.still_s, ""
        still_s = min(max(s.still_s + shift, s.suspect_s), 4 * s.still_s)
        return still_s, f" (threshold {still_s:.1f} s: operator feedback moved it {still_s - s.still_s:+.1f} s)"

    def _shelter(self, world: WorldModel, person: WorldObject) -> Landmark | None:
        s = self.settings
        near = [
            (math.hypot(lm.north - person.pose.north, lm.east - person.pose.east), lm)
            for lm in world.landmarks
            if lm.kind in s.shelter_kinds
        ]
        inside = [(d, lm) for d, lm in near if d <= max(s.shelter_radius_m, lm.radius_m or 0.0)]
        return min(inside, key=lambda x: x[0])[1] if inside else None

    def _density(self, people: list[WorldObject]) -> float:
        """The densest spot's crowd density: the most people within ``density_radius_m`` of anyone, per m²."""
        r = self.settings.density_radius_m
        points = np.array([[p.pose.north, p.pose.east] for p in people])
        counts = cKDTree(points).query_ball_point(points, r, return_length=True)
        return float(np.max(counts)) / (math.pi * r * r)

    # ---- the description ----

    def _describe(
        self, world: WorldModel, people: list[WorldObject], subject: WorldObject | None, density: float
    ) -> str:
        moving = sum(1 for p in people if p.vel.speed > 0.3)
        parts = [
            f"{len(people)} {'person' if len(people) == 1 else 'persons'} in view, {moving} moving and "
            f"{len(people) - moving} still; peak crowd density about {density:.2f} persons/m²."
        ]
        if subject is not None:
            isolation = next((r.value for r in world.relations_of(subject.id) if r.pred == "isolated_from"), None)
            detail = f" about {isolation:.0f} m from the nearest person" if isolation is not None else ""
            parts.append(
                f"{subject.id} motionless for {subject.stationary_s:.0f} s{detail}"
                f"{', isolated from pedestrian flow' if world.has(subject.id, 'isolated_from') else ''}."
            )
        where = subject or people[0]
        landmarks = self._landmarks_text(world, where.pose.north, where.pose.east)
        if landmarks:
            parts.append(landmarks)
        return " ".join(parts)

    def _landmarks_text(self, world: WorldModel, north: float, east: float) -> str:
        if not world.landmarks:
            return ""
        distance, nearest = min(
            ((math.hypot(lm.north - north, lm.east - east), lm) for lm in world.landmarks), key=lambda x: x[0]
        )
        return f"Nearest landmark: {nearest.kind.replace('_', ' ')} {nearest.id} at {distance:.0f} m."


def _rank(severity: Severity) -> int:
    return SEVERITIES.index(severity)


__all__ = ["CRITICAL_ACTIONS", "RuleReasoner", "RuleSettings", "YoloBaseline", "mean_confidence", "persons", "timed"]
