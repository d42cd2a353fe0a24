"""Operator feedback that changes decisions: answers become preference records with their evidence, a decline
moves the rules' threshold so similar evidence is acted on less, approvals the other way, and a record with absurd
evidence is refused naming its key and field."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.events import RunEvent
from agentic_core.contracts.feedback import Preference, PreferenceFeatures
from agentic_core.contracts.world_model import WorldModel
from agentic_core.memory.cli import main as memory_main
from agentic_core.memory.feedback import FeedbackError, FeedbackModel
from agentic_core.memory.fleet import FleetMemory
from agentic_core.reasoning.rules import RuleReasoner
from agentic_core.run.run_memory import RunMemory

EGO = {"north": 0, "east": 0, "down": -30, "lat": 21.4133, "lon": 39.8933, "alt": 30}


def scene(still_s: float, isolation_m: float = 31.0) -> WorldModel:
    pose = {"north": 40, "east": 5, "down": 0, "lat": 21.41366, "lon": 39.89335, "alt": 0}
    return WorldModel.model_validate({"timestamp": 30.0, "ego_pose": EGO,
        "objects": [{"id": "P-7", "class": "person", "conf": 0.85, "stationary_s": still_s, "pose": pose}],
        "relations": [{"subj": "P-7", "pred": "isolated_from", "obj": "crowd", "value": isolation_m}]})  # fmt: skip


def answer(verdict: str, still_s: float, said: str = "") -> Preference:
    features = PreferenceFeatures(severity="critical", confidence=0.85, stationary_s=still_s, isolation_m=31.0)
    return Preference(verdict=verdict, action="land", features=features, said=said)


def severity(rules: RuleReasoner, still_s: float) -> str:
    a = rules.assess(scene(still_s)).assessment
    assert a is not None
    return a.severity


def test_a_decline_lowers_the_probability_of_acting_on_similar_evidence() -> None:
    evidence = answer("declined", 12.0).features
    before, after = FeedbackModel.fit([]), FeedbackModel.fit([answer("declined", 12.0)])
    assert after.p_approve(evidence) < before.p_approve(evidence)
    assert before.shift(evidence) == 0.0 and after.shift(evidence) > 0.0
    plain, taught = RuleReasoner(), RuleReasoner()
    taught.prior = after
    assert severity(plain, 12.0) == "critical"  # the table alone acts at 10 s
    assert severity(taught, 12.0) == "high"  # after the decline: a look, not a landing
    a = taught.assess(scene(12.0)).assessment
    assert a is not None and "operator feedback moved it +" in a.rationale
    assert severity(taught, 40.0) == "critical"  # far stiller than anything declined: still acted on


def test_approvals_lower_the_threshold_the_other_way() -> None:
    rules = RuleReasoner()
    rules.prior = FeedbackModel.fit([answer("approved", 6.0), answer("edited", 7.0)])
    assert severity(RuleReasoner(), 8.0) == "high" and severity(rules, 8.0) == "critical"


def test_a_prior_that_fails_leaves_the_table_standing() -> None:
    rules = RuleReasoner()

    def broken(features: PreferenceFeatures) -> float:
        raise RuntimeError("model gone")

    rules.prior = broken
    assert severity(rules, 12.0) == "critical"
    rules.prior = lambda f: float("nan")
    assert severity(rules, 12.0) == "critical"


def event(kind: str, seq: int, **fields: Any) -> RunEvent:
    return RunEvent(kind=kind, seq=seq, sim_t=seq * 1.0, **fields)


def test_answers_in_a_run_become_preference_records_with_provenance_and_change_the_next_run(tmp_path: Path) -> None:
    path = tmp_path / "memory.db"
    first = RunMemory(path, "R1", view=dict, locate=lambda o: None, mission="m", scene="s")
    first.recall(scene(12.0))  # the reasoner looked at P-7: the evidence of what follows
    rec = first.recorder
    rec.on_event(event("decision", 5, assessment={"severity": "critical", "subject_id": "P-7", "confidence": 0.85,
                                                  "rationale": "down"}))  # fmt: skip
    request = {"step": "emergency/land_near", "action": "land", "args": {"target_id": "P-7"}, "question": "land?"}
    rec.on_event(event("approval", 6, request=request, answer=False, via="operator", said="a family is with him"))
    rec.on_event(event("approval", 7, request=request, answer=True, via="policy"))  # headless: nobody's preference
    rec.flush()
    first.fleet.close()

    fleet = FleetMemory(path, embed=False)
    model = FeedbackModel.load(fleet)
    ((memory, pref),) = model.records
    assert pref.verdict == "declined" and pref.object_id == "P-7" and pref.step == "emergency/land_near"
    seen = pref.features
    assert seen.stationary_s == 12.0 and seen.isolation_m == 31.0 and seen.severity == "critical"
    assert memory.provenance.run_id == "R1" and memory.provenance.seq == 6
    fleet.close()

    second = RunMemory(path, "R2", view=dict, locate=lambda o: None, mission="m", scene="s")
    rules = RuleReasoner()
    second.wrap(rules)
    assert rules.prior is second.feedback and severity(rules, 12.0) == "high"
    second.fleet.close()


def put_preference(path: Path, key: str, preference: dict[str, Any]) -> None:
    fleet = FleetMemory(path, embed=False)
    fleet.remember("approval", key, "operator declined", preference=preference)
    fleet.close()


ABSURD = [("confidence", 7.0), ("stationary_s", -3.0), ("stationary_s", 1e12), ("isolation_m", 1e9),
          ("confidence", "sure"), ("object_class", "Person; rm -rf")]  # fmt: skip


@pytest.mark.parametrize(("field", "bad"), ABSURD)
def test_absurd_features_are_refused_naming_the_record_and_field(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], field: str, bad: Any
) -> None:
    features = {"severity": "critical", "confidence": 0.8, "stationary_s": 12.0, "isolation_m": 30.0, field: bad}
    path = tmp_path / "memory.db"
    put_preference(path, "R9:4", {"verdict": "declined", "features": features})
    fleet = FleetMemory(path, embed=False)
    with pytest.raises(FeedbackError, match=rf"preference approval/R9:4: field features\.{field}"):
        FeedbackModel.load(fleet)
    fleet.close()
    assert issubclass(FeedbackError, InputError)
    assert memory_main(["--memory", str(path), "feedback"]) == 2  # one line, no traceback
    err = capsys.readouterr().err
    assert f"features.{field}" in err and "Traceback" not in err
    run = RunMemory(path, "R10", view=dict, locate=lambda o: None, mission="m", scene="s")  # a run still flies
    rules = RuleReasoner()
    run.wrap(rules)
    assert rules.prior is None and run.feedback_error is not None and "R9:4" in run.feedback_error
    run.fleet.close()


def test_the_cli_shows_the_fitted_model(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "memory.db"
    put_preference(path, "R1:6", answer("declined", 12.0).model_dump())
    assert memory_main(["--memory", str(path), "feedback"]) == 0
    out = capsys.readouterr().out
    assert "1 operator answers (0 approved, 1 declined, 0 edited)" in out and "logit P(approve) =" in out
    assert "threshold shift" in out
    assert memory_main(["--memory", str(path), "feedback", "--still-s", "-1"]) == 2
