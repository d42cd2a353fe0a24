"""The rule reasoner's severity table and the YOLO baseline, on hand-built World Models."""

from __future__ import annotations

from typing import Any

import pytest

from agentic_core.perception.world_model import WorldModel
from agentic_core.reasoning.rules import CRITICAL_ACTIONS, RuleReasoner, RuleSettings, YoloBaseline

EGO = {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30}


def person(
    pid: str,
    north: float,
    east: float,
    *,
    still: float = 0.0,
    speed: float = 1.2,
    conf: float = 0.8,
    state: str = "confirmed",
) -> dict[str, Any]:
    return {
        "id": pid,
        "class": "person",
        "conf": conf,
        "stationary_s": still,
        "state": state,
        "vel": {"north": speed, "east": 0.0, "speed": speed},
        "pose": {"north": north, "east": east, "down": 0, "lat": 21.4133, "lon": 39.8933, "alt": 0},
    }


def world(
    objects: list[dict[str, Any]], isolated: tuple[str, ...] = (), landmarks: list[dict[str, Any]] | None = None
) -> WorldModel:
    relations = [{"subj": pid, "pred": "isolated_from", "obj": "crowd", "value": 30.0} for pid in isolated]
    return WorldModel.model_validate(
        {"timestamp": 60.0, "ego_pose": EGO, "objects": objects, "relations": relations, "landmarks": landmarks or []}
    )


def crowd(n: int, north: float = 0.0) -> list[dict[str, Any]]:
    return [person(f"P-{i}", north + (i % 5) * 2.0, (i // 5) * 2.0) for i in range(n)]


def test_a_collapsed_isolated_person_is_critical_with_the_papers_actions() -> None:
    w = world([*crowd(10), person("P-99", 60, 0, still=14, speed=0, conf=0.89)], isolated=("P-99",))
    a = RuleReasoner().assessment(w)
    assert (a.severity, a.subject_id, a.recommended_actions) == ("critical", "P-99", CRITICAL_ACTIONS)
    assert a.confidence == 0.89 and a.persons_detected == 11
    assert "P-99 motionless for 14 s about 30 m from the nearest person, isolated from pedestrian flow" in (
        a.surrounding_features
    )
    assert a.contextual and a.recommends_action


def test_normal_crowd_is_logged_with_a_scene_description() -> None:
    a = RuleReasoner().assessment(world(crowd(10)))
    assert (a.severity, a.recommended_actions, a.subject_id) == ("none", ["log_crowd_density"], None)
    assert a.surrounding_features.startswith("10 persons in view, 10 moving and 0 still")
    assert a.contextual
    assert a.confidence == pytest.approx(0.8)


def test_a_person_resting_at_a_shelter_is_not_an_emergency() -> None:
    tent = {"id": "T-1", "kind": "shade", "north": 62, "east": 3}
    a = RuleReasoner().assessment(world([person("P-1", 60, 0, still=40, speed=0)], ("P-1",), [tent]))
    assert (a.severity, a.recommended_actions) == ("low", ["log_observation"])
    assert "resting at shade T-1" in a.rationale


def test_stopped_for_part_of_the_threshold_is_high_and_asks_to_confirm() -> None:
    settings = RuleSettings(still_s=10, suspect_s=3)
    a = RuleReasoner(settings).assessment(world([person("P-1", 60, 0, still=6, speed=0)], ("P-1",)))
    assert (a.severity, a.recommended_actions) == ("high", ["approach_and_confirm"])
    a = RuleReasoner(settings).assessment(world([person("P-1", 60, 0, still=2, speed=0)], ("P-1",)))
    assert a.severity == "none"


def test_stationary_in_the_crowd_is_not_isolated_so_not_critical() -> None:
    objects = [*crowd(10), person("P-50", 2, 2, still=30, speed=0)]
    assert RuleReasoner().assessment(world(objects)).severity == "none"


def test_a_dense_crowd_is_noted() -> None:
    packed = [person(f"P-{i}", (i % 10) * 0.5, (i // 10) * 0.5) for i in range(200)]
    a = RuleReasoner().assessment(world(packed))
    assert a.severity == "low" and a.recommended_actions == ["log_crowd_density"] and "dense" in a.rationale


def test_nobody_in_view_and_tentative_tracks_do_not_count() -> None:
    a = RuleReasoner().assessment(world([person("P-1", 0, 0, state="tentative")]))
    assert (a.persons_detected, a.severity, a.recommended_actions, a.confidence) == (0, "none", ["continue_patrol"], 0)


def test_focus_assesses_the_object_asked_about() -> None:
    objects = [person("P-1", 60, 0, still=14, speed=0), person("P-2", -60, 0, still=6, speed=0)]
    a = RuleReasoner().assessment(world(objects, ("P-1", "P-2")), focus="P-2")
    assert (a.subject_id, a.severity) == ("P-2", "high")


def test_yolo_baseline_counts_and_reports_confidence_only() -> None:
    w = world([*crowd(4), person("P-99", 60, 0, still=14, speed=0, conf=1.0)], isolated=("P-99",))
    decision = YoloBaseline().assess(w)
    assert decision.ok and decision.reasoner == "yolo" and decision.processing_time_s >= 0
    a = decision.assessment
    assert a is not None
    assert (a.persons_detected, a.severity, a.recommended_actions, a.surrounding_features) == (5, "none", [], "")
    assert a.confidence == pytest.approx((4 * 0.8 + 1.0) / 5)


def test_a_reasoner_that_breaks_gives_a_failed_decision_not_an_exception() -> None:
    class Broken(RuleReasoner):
        def assessment(self, world: WorldModel, focus: str | None = None) -> Any:
            raise RuntimeError("boom")

    decision = Broken().assess(world([]))
    assert not decision.ok and decision.error == "RuntimeError: boom"


def test_a_lost_track_still_counts_a_person_missed_for_a_few_frames_has_not_gone() -> None:
    w = world([person("P-9", 60, 0, still=14, speed=0, state="lost")], isolated=("P-9",))
    a = RuleReasoner().assessment(w)
    assert (a.severity, a.subject_id, a.persons_detected) == ("critical", "P-9", 1)
