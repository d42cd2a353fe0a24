"""The campaign's metrics per system: the paper's, by its exact definitions, and the ground-truth ones it lacked.

Every rate's denominator holds every record of the system, failed ones included (a failure is an assessment that
did not happen: no person detected, no action, not contextual, not the right severity). Definitions
(:data:`DEFINITIONS`, also written under the table):

The paper's (§ Experimental Validation, Table 2):

* **processing time** — mean ± sample SD of ``processing_time_s``, the system's wall time per assessment over
  the episode, model calls included (a hybrid's reused answer does not hide the call it came from), and the
  model's share of that time;
* **detection confidence** — mean ``detection_confidence`` over the records that report a person (the
  detector's confidence for ``yolo``/``rules``, a model's self-reported one for LLMs);
* **persons detected** — records whose assessment reports at least one person: count and share;
* **Action Recommendation Rate** — ``N(actions > 0) / N × 100``;
* **Contextual Analysis Rate** — ``N(surrounding_features longer than 50 characters) / N × 100``.

From the scenes' ground truth:

* **detection precision / recall** — ``Σtp / (Σtp + Σfp)`` and ``Σtp / (Σtp + Σfn)`` over the records, where the
  counts match confirmed person tracks to the persons in view at the final frame (within the episode's gate; see
  :mod:`evaluation.campaign.episode`). They score perception, which every system reads, so they agree across the
  systems of one campaign;
* **person-count error** — mean ``|persons_detected − persons in view|`` over records with an assessment;
* **correct-severity rate** — records whose severity equals the scene's ``expected_severity``;
* **false-alarm rate** — of the records of scenes without a casualty, those assessed ``high`` or ``critical``;
* **missed-casualty rate** — of the records of scenes with a casualty, those not assessed ``high`` or ``critical``;
* **intervention rate** — of the records in which a casualty came into view, those with a time to intervention;
* **time to intervention** — mean, median and maximum over the records that have one (seconds of simulation).

>>> from evaluation.campaign.records import DecisionRecord
>>> def rec(system, severity, expected, actions=0):
...     return DecisionRecord(scene_id=expected, system=system, processing_time_s=0.5, person_detected=True,
...         n_actions=actions, action_recommended=actions > 0, contextual=False, severity=severity,
...         expected_severity=expected, casualties=int(expected == "critical"), persons_detected=1)
>>> m = compute_metrics([rec("rules", "critical", "critical", 3), rec("rules", "high", "none", 1)])
>>> m.systems[0].correct_severity_rate, m.systems[0].false_alarm_rate, m.systems[0].action_recommendation_rate
(0.5, 1.0, 1.0)
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import Iterable, Sequence
from pathlib import Path

from pydantic import BaseModel, ConfigDict

from .records import DecisionRecord

ALARM = frozenset({"high", "critical"})

DEFINITIONS: dict[str, str] = {
    "processing_time": "the system's wall time per assessment over the episode (model calls included): "
    "mean ± sample SD",
    "model_time_share": "of the systems' time over every episode, the share its model took",
    "detection_confidence": "mean detection_confidence over the records that report at least one person",
    "persons_detected": "records whose assessment reports at least one person (count, share of all records)",
    "action_recommendation_rate": "records with at least one recommended action / all records",
    "contextual_analysis_rate": "records whose surrounding_features is longer than 50 characters / all records",
    "detection_precision": "Σtp / (Σtp + Σfp): confirmed person tracks at the final frame matched one-to-one to "
    "persons in view within the match gate",
    "detection_recall": "Σtp / (Σtp + Σfn): persons in view at the final frame matched by a confirmed person track",
    "count_error": "mean |persons_detected − persons in view| over the records with an assessment",
    "correct_severity_rate": "records whose severity equals the scene's expected severity / all records",
    "false_alarm_rate": "records of scenes without a casualty assessed high or critical / those records",
    "missed_casualty_rate": "records of scenes with a casualty not assessed high or critical / those records",
    "intervention_rate": "records with a time to intervention / records in which a casualty came into view",
    "model_calls": "model calls over every episode (assessments, repairs included) beside the assessments made; "
    "saved (hybrid): assessments answered by the rules alone or from an identical earlier situation, each a model "
    "call in the llm design",
    "time_to_intervention": "simulation time from a casualty's first frame in view to the first critical decision "
    "naming it (its subject's track within the match gate): mean, median, max over the records that have one",
}


class SystemMetrics(BaseModel):
    """One system's metrics (rates are fractions 0–1; ``None`` where the denominator is empty)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    system: str
    n: int
    errors: int
    processing_time_mean_s: float | None
    processing_time_sd_s: float | None
    processing_time_median_s: float | None
    model_time_share: float | None = None
    detection_confidence_mean: float | None
    persons_detected: int
    persons_detected_rate: float | None
    action_recommendation_rate: float | None
    contextual_analysis_rate: float | None
    detection_precision: float | None
    detection_recall: float | None
    count_error: float | None
    correct_severity_rate: float | None
    false_alarm_rate: float | None
    no_casualty_records: int
    missed_casualty_rate: float | None
    casualty_records: int
    intervention_rate: float | None
    casualty_in_view_records: int
    time_to_intervention_mean_s: float | None
    time_to_intervention_median_s: float | None
    time_to_intervention_max_s: float | None
    assessments: int = 0
    model_calls: int = 0
    model_calls_saved: int | None = None


class CampaignMetrics(BaseModel):
    """The metrics of every system of a campaign, and their definitions."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    systems: list[SystemMetrics]
    definitions: dict[str, str] = DEFINITIONS

    def system(self, name: str) -> SystemMetrics:
        return next(s for s in self.systems if s.system == name)

    def to_json(self) -> str:
        return json.dumps(self.model_dump(mode="json"), indent=2) + "\n"

    def to_markdown(self) -> str:
        """A table in the layout of the paper's Table 2 (metrics as rows, systems as columns), then definitions."""
        return render_markdown(self)


def compute_metrics(records: Iterable[DecisionRecord], systems: Sequence[str] | None = None) -> CampaignMetrics:
    """The metrics of each system (in ``systems`` order, else in order of first appearance)."""
    by_system: dict[str, list[DecisionRecord]] = {name: [] for name in systems or ()}
    for record in records:
        by_system.setdefault(record.system, []).append(record)
    return CampaignMetrics(systems=[system_metrics(name, rows) for name, rows in by_system.items()])


def system_metrics(name: str, records: Sequence[DecisionRecord]) -> SystemMetrics:
    """One system's metrics from its records (see the module docs for each definition)."""
    n = len(records)
    times = [r.processing_time_s for r in records]
    confidences = [r.detection_confidence for r in records if r.person_detected and r.detection_confidence is not None]
    tp = sum(r.detection_tp for r in records)
    fp = sum(r.detection_fp for r in records)
    fn = sum(r.detection_fn for r in records)
    assessed = [r for r in records if r.persons_detected is not None]
    calm = [r for r in records if r.casualties == 0]
    casualty = [r for r in records if r.casualties > 0]
    seen = [r for r in records if r.casualty_in_view]
    tti = [r.time_to_intervention_s for r in records if r.time_to_intervention_s is not None]
    persons = sum(r.person_detected for r in records)
    assessments = sum(r.assessments for r in records)
    calls = sum(r.episode_llm_calls for r in records)
    return SystemMetrics(
        system=name,
        n=n,
        errors=sum(r.assessment is None for r in records),
        processing_time_mean_s=statistics.fmean(times) if times else None,
        processing_time_sd_s=statistics.stdev(times) if len(times) > 1 else None,
        processing_time_median_s=statistics.median(times) if times else None,
        model_time_share=_fraction(
            sum(r.episode_model_time_s for r in records), sum(r.episode_time_s for r in records)
        ),
        detection_confidence_mean=statistics.fmean(confidences) if confidences else None,
        persons_detected=persons,
        persons_detected_rate=_share(persons, n),
        action_recommendation_rate=_share(sum(r.n_actions > 0 for r in records), n),
        contextual_analysis_rate=_share(sum(r.contextual for r in records), n),
        detection_precision=_share(tp, tp + fp),
        detection_recall=_share(tp, tp + fn),
        count_error=statistics.fmean(abs((r.persons_detected or 0) - r.persons_in_view) for r in assessed)
        if assessed
        else None,
        correct_severity_rate=_share(sum(r.severity == r.expected_severity for r in records), n),
        false_alarm_rate=_share(sum(r.severity in ALARM for r in calm), len(calm)),
        no_casualty_records=len(calm),
        missed_casualty_rate=_share(sum(r.severity not in ALARM for r in casualty), len(casualty)),
        casualty_records=len(casualty),
        intervention_rate=_share(sum(r.time_to_intervention_s is not None for r in seen), len(seen)),
        casualty_in_view_records=len(seen),
        time_to_intervention_mean_s=statistics.fmean(tti) if tti else None,
        time_to_intervention_median_s=statistics.median(tti) if tti else None,
        time_to_intervention_max_s=max(tti) if tti else None,
        assessments=assessments,
        model_calls=calls,
        model_calls_saved=assessments - calls if any(r.reasoner.startswith("hybrid") for r in records) else None,
    )


def _share(part: int, whole: int) -> float | None:
    return part / whole if whole else None


def _fraction(part: float, whole: float) -> float | None:
    return min(part / whole, 1.0) if whole > 0 else None


# --------------------------------------------------------------------------- rendering


def render_markdown(metrics: CampaignMetrics) -> str:
    systems = metrics.systems
    header = "| Metric | " + " | ".join(s.system for s in systems) + " |"
    rule = "|---|" + "---|" * len(systems)
    rows: list[tuple[str, list[str]]] = [
        ("Records (n)", [f"{s.n}" + (f" ({s.errors} failed)" if s.errors else "") for s in systems]),
        ("Processing time (mean ± SD)", [_time(s) for s in systems]),
        ("Model's share of the time", [_pct(s.model_time_share) for s in systems]),
        ("Detection confidence", [_num(s.detection_confidence_mean) for s in systems]),
        ("Persons detected", [f"{s.persons_detected} ({_pct(s.persons_detected_rate)})" for s in systems]),
        ("Action Recommendation Rate", [_pct(s.action_recommendation_rate) for s in systems]),
        ("Contextual Analysis Rate", [_pct(s.contextual_analysis_rate) for s in systems]),
        ("Detection precision", [_pct(s.detection_precision) for s in systems]),
        ("Detection recall", [_pct(s.detection_recall) for s in systems]),
        ("Person-count error (mean abs.)", [_num(s.count_error, 2) for s in systems]),
        ("Correct severity", [_pct(s.correct_severity_rate) for s in systems]),
        ("False alarms", [f"{_pct(s.false_alarm_rate)} of {s.no_casualty_records}" for s in systems]),
        ("Missed casualties", [f"{_pct(s.missed_casualty_rate)} of {s.casualty_records}" for s in systems]),
        ("Interventions", [f"{_pct(s.intervention_rate)} of {s.casualty_in_view_records}" for s in systems]),
        ("Time to intervention (mean / median / max)", [_tti(s) for s in systems]),
        ("Model calls / assessments (saved)", [_calls(s) for s in systems]),
    ]
    lines = ["# Campaign metrics", "", header, rule]
    lines += [f"| {label} | " + " | ".join(cells) + " |" for label, cells in rows]
    lines += ["", "Rates count every record of a system, failed ones included. Definitions:", ""]
    lines += [f"* **{name.replace('_', ' ')}**: {text}" for name, text in metrics.definitions.items()]
    return "\n".join(lines) + "\n"


def _calls(s: SystemMetrics) -> str:
    saved = f" ({s.model_calls_saved} saved)" if s.model_calls_saved is not None else ""
    return f"{s.model_calls} / {s.assessments}{saved}"


def _pct(value: float | None) -> str:
    return "–" if value is None else f"{100.0 * value:.1f}%"


def _num(value: float | None, digits: int = 3) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def _seconds(value: float) -> str:
    if value < 1e-3:
        return f"{value * 1e6:.1f} µs"
    if value < 1.0:
        return f"{value * 1e3:.2f} ms"
    return f"{value:.2f} s"


def _time(s: SystemMetrics) -> str:
    if s.processing_time_mean_s is None:
        return "–"
    sd = s.processing_time_sd_s
    if sd is None or math.isnan(sd):
        return _seconds(s.processing_time_mean_s)
    mean_text, sd_text = _seconds(s.processing_time_mean_s), _seconds(sd)
    mean_value, unit = mean_text.rsplit(" ", 1)
    if sd_text.endswith(" " + unit):
        return f"{mean_value} ± {sd_text}"
    return f"{mean_text} ± {sd_text}"


def _tti(s: SystemMetrics) -> str:
    if s.time_to_intervention_mean_s is None:
        return "–"
    parts = (s.time_to_intervention_mean_s, s.time_to_intervention_median_s, s.time_to_intervention_max_s)
    return " / ".join(f"{p:.1f}" for p in parts if p is not None) + " s"


def write_metrics(out_dir: Path, metrics: CampaignMetrics) -> tuple[Path, Path]:
    """Write ``metrics.md`` and ``metrics.json`` into ``out_dir``; returns their paths."""
    md, js = out_dir / "metrics.md", out_dir / "metrics.json"
    md.write_text(metrics.to_markdown(), encoding="utf-8")
    js.write_text(metrics.to_json(), encoding="utf-8")
    return md, js


__all__ = ["DEFINITIONS", "CampaignMetrics", "SystemMetrics", "compute_metrics", "system_metrics", "write_metrics"]
