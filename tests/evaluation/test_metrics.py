"""The campaign metrics on hand-built records, against values computed by hand."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from agentic_core.reasoning.assessment import Assessment
from evaluation.campaign.metrics import DEFINITIONS, compute_metrics, write_metrics
from evaluation.campaign.records import DecisionRecord

LONG = "Four persons walking north along the road, one lying still 20 m east of the flow, no shade near."


def record(
    scene: str,
    system: str,
    *,
    time_s: float,
    severity: str | None,
    expected: str,
    persons: int | None = 1,
    conf: float = 0.7,
    actions: int = 0,
    text: str = "",
    casualties: int = 0,
    in_view: bool = False,
    tti: float | None = None,
    tp: int = 0,
    fp: int = 0,
    fn: int = 0,
    truth: int = 0,
) -> DecisionRecord:
    assessment = None
    if severity is not None:
        assessment = Assessment(
            persons_detected=persons or 0,
            confidence=conf,
            surrounding_features=text,
            severity=severity,
            recommended_actions=[f"a{i}" for i in range(actions)],
        )
    seen = assessment is not None and assessment.persons_detected > 0
    data: dict[str, Any] = {
        "scene_id": scene,
        "system": system,
        "processing_time_s": time_s,
        "detection_confidence": conf if seen else None,
        "person_detected": seen,
        "n_actions": actions if assessment else 0,
        "action_recommended": bool(assessment and actions),
        "contextual": bool(assessment and assessment.contextual),
        "error": None if assessment else "http_error: 400",
        "severity": severity,
        "persons_detected": persons if assessment else None,
        "assessment": assessment,
        "expected_severity": expected,
        "casualties": casualties,
        "casualty_in_view": in_view,
        "time_to_intervention_s": tti,
        "detection_tp": tp,
        "detection_fp": fp,
        "detection_fn": fn,
        "persons_in_view": truth,
    }
    return DecisionRecord.model_validate(data)


@pytest.fixture
def records() -> list[DecisionRecord]:
    return [
        # system A: a calm scene right, a casualty found, a casualty missed, a failure
        record("s1", "A", time_s=1.0, severity="none", expected="none", persons=4, conf=0.8, tp=3, fp=1, truth=3),
        record(
            "s2", "A", time_s=3.0, severity="critical", expected="critical", persons=2, conf=0.6, actions=3,
            text=LONG, casualties=1, in_view=True, tti=10.0, tp=2, fn=2, truth=4,
        ),
        record("s3", "A", time_s=2.0, severity="none", expected="high", persons=0, casualties=1, in_view=True, truth=1,
               fn=1),
        record("s4", "A", time_s=0.5, severity=None, expected="none", truth=2, tp=2),
        # system B: raises an alarm in a calm scene, intervenes in both casualty scenes
        record("s1", "B", time_s=4.0, severity="high", expected="none", persons=3, conf=0.9, actions=1, text=LONG),
        record("s2", "B", time_s=6.0, severity="critical", expected="critical", actions=2, casualties=1, in_view=True,
               tti=11.0),
        record("s3", "B", time_s=5.0, severity="critical", expected="high", actions=2, casualties=1, in_view=True,
               tti=13.0),
    ]  # fmt: skip


def test_the_papers_metrics_by_their_definitions(records: list[DecisionRecord]) -> None:
    a = compute_metrics(records).system("A")
    assert (a.n, a.errors) == (4, 1)
    assert a.processing_time_mean_s == pytest.approx(1.625)
    assert a.processing_time_sd_s == pytest.approx(math.sqrt(3.6875 / 3))
    assert a.processing_time_median_s == pytest.approx(1.5)
    assert a.detection_confidence_mean == pytest.approx(0.7)  # only records that report a person
    assert (a.persons_detected, a.persons_detected_rate) == (2, 0.5)
    assert a.action_recommendation_rate == 0.25  # N(actions > 0) / N, the failure in the denominator
    assert a.contextual_analysis_rate == 0.25  # surrounding_features over 50 characters


def test_the_ground_truth_metrics(records: list[DecisionRecord]) -> None:
    metrics = compute_metrics(records)
    a, b = metrics.system("A"), metrics.system("B")
    assert a.detection_precision == pytest.approx(7 / 8)  # Σtp 7, Σfp 1
    assert a.detection_recall == pytest.approx(7 / 10)  # Σfn 3
    assert a.count_error == pytest.approx((1 + 2 + 1) / 3)  # |4-3|, |2-4|, |0-1| over the assessed records
    assert a.correct_severity_rate == 0.5  # s1 and s2 right; s3 wrong; the failure wrong
    assert (a.false_alarm_rate, a.no_casualty_records) == (0.0, 2)
    assert (a.missed_casualty_rate, a.casualty_records) == (0.5, 2)
    assert (a.intervention_rate, a.casualty_in_view_records) == (0.5, 2)
    assert (a.time_to_intervention_mean_s, a.time_to_intervention_max_s) == (10.0, 10.0)
    assert (b.false_alarm_rate, b.missed_casualty_rate, b.intervention_rate) == (1.0, 0.0, 1.0)
    assert b.correct_severity_rate == pytest.approx(1 / 3)
    assert b.time_to_intervention_mean_s == 12.0 and b.time_to_intervention_median_s == 12.0
    assert b.detection_precision is None and b.detection_recall is None  # no tracks, no truth: no denominator


def test_systems_keep_the_order_asked_for_and_empty_ones_have_no_values(records: list[DecisionRecord]) -> None:
    metrics = compute_metrics(records, ["B", "A", "C"])
    assert [s.system for s in metrics.systems] == ["B", "A", "C"]
    c = metrics.system("C")
    assert c.n == 0 and c.processing_time_mean_s is None and c.action_recommendation_rate is None


def test_markdown_and_json(records: list[DecisionRecord], tmp_path: Path) -> None:
    metrics = compute_metrics(records)
    md_path, json_path = write_metrics(tmp_path, metrics)
    md = md_path.read_text(encoding="utf-8")
    assert "| Metric | A | B |" in md
    assert "| Records (n) | 4 (1 failed) | 3 |" in md
    assert "| Processing time (mean ± SD) | 1.62 ± 1.11 s | 5.00 ± 1.00 s |" in md
    assert "| Action Recommendation Rate | 25.0% | 100.0% |" in md
    assert "| False alarms | 0.0% of 2 | 100.0% of 1 |" in md
    assert "| Time to intervention (mean / median / max) | 10.0 / 10.0 / 10.0 s | 12.0 / 12.0 / 13.0 s |" in md
    assert all(f"**{name.replace('_', ' ')}**" in md for name in DEFINITIONS)
    data = json.loads(json_path.read_text(encoding="utf-8"))
    assert data["systems"][0]["system"] == "A" and data["systems"][0]["correct_severity_rate"] == 0.5
    assert data["definitions"]["contextual_analysis_rate"].startswith("records whose surrounding_features")


def test_small_times_in_microseconds() -> None:
    rows = [record(f"s{i}", "yolo", time_s=t, severity="none", expected="none") for i, t in enumerate([2e-5, 4e-5])]
    md = compute_metrics(rows).to_markdown()
    assert "| Processing time (mean ± SD) | 30.0 ± 14.1 µs |" in md
