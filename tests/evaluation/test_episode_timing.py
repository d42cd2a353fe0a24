"""A system's processing time includes its model calls: a hybrid whose final answer was reused from an earlier
model call took the model's time, and the record says the model's share of it."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from agentic_core.reasoning.assessment import Assessment, Decision
from agentic_core.reasoning.reasoners import Reasoner
from evaluation.campaign import episode
from evaluation.campaign.episode import EpisodeSettings, run_episode
from evaluation.campaign.metrics import compute_metrics
from evaluation.campaign.systems import SystemSpec
from flight.sim.scene_gen import generate_scene

ANSWER = Assessment(
    persons_detected=1, confidence=0.9, surrounding_features="", severity="critical",
    recommended_actions=["alert_medical_team"], rationale="collapsed",
)  # fmt: skip


class SlowThenCached:
    """The first assessment is a 2-second model call (1.8 s of it the model's); every later one is reused."""

    name = "hybrid"

    def __init__(self) -> None:
        self.calls = 0

    def assess(self, world: object, focus: str | None = None) -> Decision:
        self.calls += 1
        if self.calls == 1:
            return Decision(reasoner=self.name, assessment=ANSWER, processing_time_s=2.0, model_time_s=1.8, llm_calls=1)
        return Decision(reasoner=self.name, assessment=ANSWER, processing_time_s=0.0005, cached=True)


def test_a_reused_answer_does_not_hide_the_model_call_it_came_from(monkeypatch: pytest.MonkeyPatch) -> None:
    def build(system: SystemSpec, **_: object) -> tuple[Reasoner, Callable[[], None]]:
        return SlowThenCached(), lambda: None

    monkeypatch.setattr(episode, "build_reasoner", build)
    scene = generate_scene(5, persons=20, casualties=1, distractors=0)
    (record,) = run_episode(scene, [SystemSpec(name="hybrid", kind="hybrid", llm="x")], EpisodeSettings(frames=120))
    assert record.assessments == 4 and record.cached  # the final assessment was a reused answer
    total = 2.0 + 3 * 0.0005
    assert record.episode_time_s == pytest.approx(total)
    assert record.episode_model_time_s == pytest.approx(1.8)
    assert record.processing_time_s == pytest.approx(total / 4)  # per assessment, the model call included
    assert record.model_time_s == pytest.approx(1.8 / 4)
    metrics = compute_metrics([record])
    assert metrics.systems[0].model_time_share == pytest.approx(1.8 / total)
    assert "Model's share of the time | 89.9%" in metrics.to_markdown()
