"""The Assessment and Decision contracts: the paper's rates come from them, so their definitions are tested."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from agentic_core.reasoning.assessment import SEVERITIES, Assessment, Decision


def test_contextual_means_more_than_fifty_characters_of_surroundings() -> None:
    assert not Assessment(persons_detected=1, confidence=0.7, surrounding_features="x" * 50).contextual
    assert Assessment(persons_detected=1, confidence=0.7, surrounding_features="x" * 51).contextual
    assert not Assessment(persons_detected=1, confidence=0.7, surrounding_features=" " * 60).contextual


def test_an_action_is_recommended_when_there_is_at_least_one() -> None:
    assert not Assessment(persons_detected=0, confidence=0.5).recommends_action
    assert Assessment(persons_detected=0, confidence=0.5, recommended_actions=["continue_patrol"]).recommends_action


def test_severity_is_ordered() -> None:
    high = Assessment(persons_detected=1, confidence=0.9, severity="high")
    assert [high.at_least(s) for s in SEVERITIES] == [True, True, True, False]


@pytest.mark.parametrize(
    ("field", "value"),
    [("confidence", 1.2), ("confidence", -0.1), ("persons_detected", -1), ("severity", "urgent"), ("mood", "ok")],
)
def test_out_of_contract_values_are_refused_by_name(field: str, value: object) -> None:
    data = {"persons_detected": 1, "confidence": 0.5, field: value}
    with pytest.raises(ValidationError, match=field):
        Assessment.model_validate(data)


def test_a_failed_decision_carries_its_error_and_no_assessment() -> None:
    failed = Decision(reasoner="llm:gpt-4o", assessment=None, processing_time_s=1.5, error="timeout")
    assert not failed.ok and failed.error == "timeout"
    assert Decision(reasoner="rules", assessment=Assessment(persons_detected=0, confidence=1.0), processing_time_s=0).ok
