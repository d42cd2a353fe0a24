"""Operator feedback, measured: the rules on held-out scenes before and after a simulated operator's answers.

**Protocol.** Training scenes go through the ``rules`` system (the campaign's observation protocol,
:func:`~evaluation.campaign.episode.run_episode`); at the first ``critical`` decision of each, a simulated operator
who knows the ground truth answers: approve when the decision named a true casualty, decline otherwise. The answers
are fitted (:class:`~agentic_core.memory.feedback.FeedbackModel`). Held-out scenes (other seeds) then go through
``before`` (the rules) and ``after`` (the same rules with the fitted prior) in one episode each, so both read the
same World Models: a paired comparison. Outcomes per scene: time to intervention (scenes where both intervened) and
a correct severity (all scenes), each compared by the Wilcoxon signed-rank test
(:func:`~evaluation.stats.paired.paired_test`), whatever the result.

    agentic-uav eval feedback --train 4 --held-out 8 --out runs/feedback-study
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from agentic_core.contracts.errors import AgenticUAVError, option_problem, report_error
from agentic_core.contracts.feedback import Preference, PreferenceFeatures
from agentic_core.contracts.world_model import WorldModel
from agentic_core.memory.feedback import FeedbackModel
from agentic_core.reasoning.assessment import Decision
from agentic_core.reasoning.reasoners import Reasoner
from agentic_core.reasoning.rules import RuleReasoner
from evaluation.stats.paired import PairedResult, paired_test
from flight.sim.scene_gen import generate_scene
from flight.sim.scene_model import Scene

from .episode import EpisodeSettings, run_episode
from .records import DecisionRecord
from .systems import SystemSpec

RULES = SystemSpec(name="rules", kind="rules")
BEFORE, AFTER = SystemSpec(name="before", kind="rules"), SystemSpec(name="after", kind="rules")


class StudySettings(BaseModel):
    """How big and how fast: a few small scenes by default (minutes on two cores)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    train: int = Field(default=4, ge=1, le=200)
    held_out: int = Field(default=8, ge=2, le=500)
    persons: int = Field(default=40, ge=1, le=2000, description="pilgrims on the walkway of each scene")
    seed: int = Field(default=0, ge=0)
    frames: int = Field(default=360, ge=30, le=10_000, description="camera frames per episode (30 Hz)")


def scenes(n: int, seed: int, persons: int, tag: str) -> list[Scene]:
    """``n`` scenes, every other one with an isolated casualty, some with resting distractors."""
    return [generate_scene(seed * 10_007 + i, persons=persons, casualties=i % 2, distractors=i % 3,
                           scene_id=f"{tag}-{seed}-{i:02d}") for i in range(n)]  # fmt: skip


class _Watch:
    """Passes assessments through, keeping the World Model of the first critical one (what the operator saw)."""

    def __init__(self, inner: Reasoner) -> None:
        self.inner, self.name = inner, inner.name
        self.first: tuple[WorldModel, Decision] | None = None

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision:
        decision = self.inner.assess(world, focus)
        a = decision.assessment
        if self.first is None and a is not None and a.severity == "critical" and a.subject_id:
            self.first = (world, decision)
        return decision


def operator_answers(train: Sequence[Scene], episode: EpisodeSettings) -> list[Preference]:
    """The simulated operator's answer at each training scene's first critical decision."""
    answers = []
    for i, scene in enumerate(train):
        watch: list[_Watch] = []

        def keep(spec: SystemSpec, r: Reasoner, watch: list[_Watch] = watch) -> Reasoner:
            watch.append(_Watch(r))
            return watch[-1]

        (record,) = run_episode(scene, [RULES], episode, wrap=keep)
        seen = watch[0].first if watch else None
        if seen is None:
            continue
        world, decision = seen
        assert decision.assessment is not None and decision.assessment.subject_id is not None
        subject = decision.assessment.subject_id
        features = PreferenceFeatures.of(world, subject, severity="critical")
        if features is None:
            continue
        truth = record.time_to_intervention_s is not None  # the decision named a true casualty
        answers.append(Preference(verdict="approved" if truth else "declined", action="land", object_id=subject,
                                  features=features, run_id=scene.id, seq=i,
                                  said="a casualty" if truth else "not a casualty"))  # fmt: skip
    return answers


def held_out_records(held: Sequence[Scene], model: FeedbackModel, episode: EpisodeSettings) -> list[DecisionRecord]:
    """``before`` and ``after`` on every held-out scene, in one episode each (the same perception)."""

    def taught(spec: SystemSpec, r: Reasoner) -> Reasoner:
        if spec.name == AFTER.name and isinstance(r, RuleReasoner):
            r.prior = model
        return r

    return [rec for scene in held for rec in run_episode(scene, [BEFORE, AFTER], episode, wrap=taught)]


def compare(records: Sequence[DecisionRecord]) -> dict[str, PairedResult | None]:
    """The paired tests: time to intervention, and a correct severity (1) or not (0)."""
    by: dict[str, dict[str, DecisionRecord]] = {}
    for r in records:
        by.setdefault(r.scene_id, {})[r.system] = r
    pairs = [(s[BEFORE.name], s[AFTER.name]) for s in by.values() if BEFORE.name in s and AFTER.name in s]
    timed = [(b.time_to_intervention_s, a.time_to_intervention_s) for b, a in pairs
             if b.time_to_intervention_s is not None and a.time_to_intervention_s is not None]  # fmt: skip
    correct = [(float(b.severity == b.expected_severity), float(a.severity == a.expected_severity)) for b, a in pairs]
    out: dict[str, PairedResult | None] = {"time_to_intervention_s": None, "correct_severity": None}
    if timed:
        out["time_to_intervention_s"] = paired_test(BEFORE.name, [t[0] for t in timed], AFTER.name,
                                                    [t[1] for t in timed])  # fmt: skip
    if correct:
        out["correct_severity"] = paired_test(BEFORE.name, [c[0] for c in correct], AFTER.name,
                                              [c[1] for c in correct])  # fmt: skip
    return out


def run_study(settings: StudySettings, out: Path | None = None) -> dict[str, Any]:
    """The whole study; writes ``feedback_study.json``, ``.md`` and the records (``records.jsonl``) under ``out``."""
    episode = EpisodeSettings(frames=settings.frames)
    train = scenes(settings.train, settings.seed, settings.persons, "train")
    held = scenes(settings.held_out, settings.seed + 1, settings.persons, "held-out")
    answers = operator_answers(train, episode)
    model = FeedbackModel.fit(answers)
    records = held_out_records(held, model, episode)
    tests = compare(records)
    report: dict[str, Any] = {
        "settings": settings.model_dump(),
        "answers": [a.model_dump() for a in answers],
        "model": model.describe(),
        "tests": {k: (v.model_dump(mode="json") if v else None) for k, v in tests.items()},
    }
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / "feedback_study.json").write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
        (out / "records.jsonl").write_text("".join(r.model_dump_json() + "\n" for r in records), encoding="utf-8")
        (out / "feedback_study.md").write_text(markdown(report, tests), encoding="utf-8")
    return report


def markdown(report: dict[str, Any], tests: dict[str, PairedResult | None]) -> str:
    s = report["settings"]
    verdicts = [a["verdict"] for a in report["answers"]]
    lines = ["# Operator feedback: before and after, on held-out scenes", "",
             f"{s['train']} training scenes, {s['held_out']} held-out scenes, {s['persons']} persons each, seed "
             f"{s['seed']}; {verdicts.count('approved')} approvals and {verdicts.count('declined')} declines "
             "from a simulated operator who knows the ground truth.", "", "## The fitted model", "", "```",
             *report["model"], "```", "", "## Paired comparisons (Wilcoxon signed-rank)", ""]  # fmt: skip
    for name, result in tests.items():
        lines.append(f"- {name}: " + (result.line() if result else "no pair to compare"))
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="agentic-uav eval feedback", description=__doc__.split("\n\n")[0])
    for name, default in StudySettings().model_dump().items():
        parser.add_argument(f"--{name.replace('_', '-')}", type=int, default=default)
    parser.add_argument("--out", type=Path, default=Path("runs") / "feedback-study")
    args = parser.parse_args(argv)
    try:
        fields = {k: getattr(args, k) for k in StudySettings.model_fields}
        settings = StudySettings(**fields)
    except ValidationError as exc:
        print(f"agentic-uav eval feedback: {option_problem(exc)}", file=sys.stderr)
        return 2
    try:
        report = run_study(settings, args.out)
    except AgenticUAVError as exc:
        return report_error("agentic-uav eval feedback", exc, sys.stderr)
    print((args.out / "feedback_study.md").read_text(encoding="utf-8"), end="")
    return 0 if report else 1


__all__ = ["StudySettings", "compare", "main", "operator_answers", "run_study"]
