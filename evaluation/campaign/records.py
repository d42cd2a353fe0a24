"""The DecisionRecord: one row of an evaluation campaign, one scene assessed by one system, and its files.

A record carries ARCHITECTURE.md's columns (``scene_id``, ``system``, ``processing_time_s``,
``detection_confidence``, ``person_detected``, ``n_actions``, ``contextual``, ``error``), ``action_recommended``
(the paper's ARR counts ``n_actions >= 1``), the raw :class:`~agentic_core.reasoning.assessment.Assessment`, what the
episode cost (perception and model time, model calls, tokens, frames), and the scene's ground truth the metrics
score against (expected severity, casualties, persons in view, detection true/false positives and misses, time to
intervention). :mod:`evaluation.campaign.episode` documents how each field is measured.

Two files hold a campaign's records, and ``agentic-uav eval stats`` reads either with no options:

* ``results.jsonl``: one JSON object per line, the assessment nested (the campaign appends to it as it goes);
* ``results.csv``: the same records with flat columns (the assessment's fields as columns, the recommended
  actions joined by ``"; "``).

>>> record = DecisionRecord(scene_id="s-1", system="yolo", processing_time_s=3e-05, detection_confidence=0.72,
...     person_detected=True, n_actions=0, action_recommended=False, contextual=False, severity="none",
...     persons_detected=4, expected_severity="none", persons_in_view=5, detection_tp=4, detection_fn=1)
>>> DecisionRecord.model_validate_json(record.model_dump_json()) == record
True
>>> csv_row(record)["person_detected"], csv_row(record)["recommended_actions"]
('true', '')
"""

from __future__ import annotations

import csv
import io
import json
import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from agentic_core.contracts.errors import InputError
from agentic_core.reasoning.assessment import Assessment, Severity
from agentic_core.run.state_files import atomic_write

TIMING_FIELDS = frozenset(
    {"processing_time_s", "model_time_s", "perception_time_s", "episode_time_s", "episode_model_time_s"}
)
"""Wall-clock measurements: the only fields two runs of the same campaign may differ in (for rule systems)."""

ACTIONS_SEPARATOR = "; "


class DecisionRecord(BaseModel):
    """One scene as one system assessed it, with what it cost and the ground truth to score it by."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scene_id: str
    system: str = Field(description="the campaign's name for the system: yolo, rules, hybrid, llm:<model>, ...")
    job_id: str = Field(default="", description="the record's content address (evaluation.campaign.jobs.job_id)")
    # --- the paper's columns -------------------------------------------------------------------------------------
    processing_time_s: float = Field(
        ge=0.0,
        description="wall time per assessment over the episode, model calls included (a reused answer's call "
        "counted when it was made)",
    )
    detection_confidence: float | None = Field(
        default=None, ge=0.0, le=1.0, description="the assessment's confidence when it reports a person; else none"
    )
    person_detected: bool = Field(description="the assessment reports at least one person")
    n_actions: int = Field(ge=0, description="recommended actions in the final assessment")
    action_recommended: bool = Field(description="n_actions >= 1 (the paper's Action Recommendation Rate)")
    contextual: bool = Field(description="surrounding_features longer than 50 characters (Contextual Analysis Rate)")
    error: str | None = Field(default=None, description="why the system gave no assessment")
    # --- the assessment --------------------------------------------------------------------------------------------
    severity: Severity | None = None
    persons_detected: int | None = Field(default=None, ge=0)
    subject_id: str | None = None
    assessment: Assessment | None = Field(default=None, description="the raw assessment (null with an error)")
    reasoner: str = Field(default="", description="the reasoner's own name (Decision.reasoner)")
    # --- what it cost ----------------------------------------------------------------------------------------------
    model_time_s: float = Field(
        default=0.0,
        ge=0.0,
        description="of processing_time_s, the model's own time (as its server says, else the wait)",
    )
    episode_time_s: float = Field(default=0.0, ge=0.0, description="the system's time over every assessment")
    episode_model_time_s: float = Field(default=0.0, ge=0.0, description="of episode_time_s, the model's")
    llm_calls: int = Field(default=0, ge=0, description="model calls of the final assessment")
    prompt_tokens: int = Field(default=0, ge=0)
    completion_tokens: int = Field(default=0, ge=0)
    cached: bool = False
    escalated: bool = False
    assessments: int = Field(default=1, ge=0, description="assessments made during the episode")
    episode_llm_calls: int = Field(default=0, ge=0, description="model calls over the whole episode")
    episode_tokens: int = Field(default=0, ge=0, description="prompt and completion tokens over the whole episode")
    perception_time_s: float = Field(default=0.0, ge=0.0, description="perception's wall time over all frames")
    frames: int = Field(default=0, ge=0, description="camera frames perception took in")
    sim_time_s: float = Field(default=0.0, ge=0.0, description="simulation time of the final assessment")
    seed: int = Field(default=0, ge=0, description="the seed of the episode's detector noise")
    # --- ground truth ----------------------------------------------------------------------------------------------
    expected_severity: Severity = "none"
    casualties: int = Field(default=0, ge=0, description="casualties in the scene")
    isolated_casualties: int = Field(default=0, ge=0)
    casualty_in_view: bool = Field(default=False, description="a casualty was in view at some frame")
    persons_in_view: int = Field(default=0, ge=0, description="persons in view at the final frame (truth)")
    detection_tp: int = Field(default=0, ge=0, description="confirmed person tracks matched to a person in view")
    detection_fp: int = Field(default=0, ge=0, description="confirmed person tracks matched to nobody")
    detection_fn: int = Field(default=0, ge=0, description="persons in view no confirmed track matched")
    time_to_intervention_s: float | None = Field(
        default=None, ge=0.0, description="casualty first in view to the first critical decision naming it"
    )

    @property
    def key(self) -> tuple[str, str]:
        """What a campaign has one record of: (scene, system)."""
        return self.scene_id, self.system

    def without_timing(self) -> dict[str, Any]:
        """The record as JSON data minus :data:`TIMING_FIELDS` (what a repeated run must reproduce exactly)."""
        data = self.model_dump(mode="json")
        for name in TIMING_FIELDS:
            data.pop(name)
        return data


CSV_COLUMNS: tuple[str, ...] = (
    *(name for name in DecisionRecord.model_fields if name != "assessment"),
    "confidence",
    "surrounding_features",
    "recommended_actions",
    "rationale",
)
"""The flat CSV columns: every record field but the nested assessment, then the assessment's own fields."""


def csv_row(record: DecisionRecord) -> dict[str, str]:
    """A record as flat CSV cells: booleans ``true``/``false``, missing values empty, actions joined by ``"; "``."""
    data = record.model_dump(mode="json", exclude={"assessment"})
    assessment = record.assessment
    data["confidence"] = assessment.confidence if assessment else None
    data["surrounding_features"] = assessment.surrounding_features if assessment else None
    data["recommended_actions"] = ACTIONS_SEPARATOR.join(assessment.recommended_actions) if assessment else None
    data["rationale"] = assessment.rationale if assessment else None
    return {name: _cell(data[name]) for name in CSV_COLUMNS}


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)


def append_record(path: Path, record: DecisionRecord) -> None:
    """Append one record to a JSONL file and make it durable (flush and fsync) before returning, so a campaign
    killed at any moment loses at most the line being written."""
    line = record.model_dump_json() + "\n"
    with path.open("a", encoding="utf-8") as fh:
        fh.write(line)
        fh.flush()
        os.fsync(fh.fileno())


def read_records(path: Path, *, repair: bool = False) -> list[DecisionRecord]:
    """The records of a JSONL file. A last line cut short (a campaign killed while writing it) is dropped, and with
    ``repair`` cut from the file; any other bad line raises :class:`RecordFileError` naming the line."""
    if not path.exists():
        return []
    raw = path.read_bytes()
    records: list[DecisionRecord] = []
    lines = raw.split(b"\n")
    complete = raw.endswith(b"\n") or not raw
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        last = number == len(lines)
        try:
            records.append(DecisionRecord.model_validate_json(line))
        except ValidationError as exc:
            if last and not complete:  # torn final write
                if repair:
                    with path.open("r+b") as fh:
                        fh.truncate(len(raw) - len(line))
                break
            raise RecordFileError(f"{path}, line {number}: not a DecisionRecord ({_first_error(exc)})") from None
    else:
        if repair and not complete:  # the last record was written whole but its newline was not
            with path.open("ab") as fh:
                fh.write(b"\n")
    return records


def write_jsonl(path: Path, records: Iterable[DecisionRecord]) -> None:
    """Write records as JSON Lines atomically (a temporary file renamed over ``path``)."""
    atomic_write(path, "".join(r.model_dump_json() + "\n" for r in records))


def write_csv(path: Path, records: Iterable[DecisionRecord]) -> None:
    """Write records as flat CSV (:data:`CSV_COLUMNS`) atomically."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(CSV_COLUMNS), lineterminator="\n")
    writer.writeheader()
    for record in records:
        writer.writerow(csv_row(record))
    atomic_write(path, buffer.getvalue())


def iter_jsonl(path: Path) -> Iterator[dict[str, Any]]:
    """The raw JSON objects of a JSONL file (for tools that want the data without the model)."""
    with path.open(encoding="utf-8") as fh:
        for line in fh:
            if line.strip():
                yield json.loads(line)


class RecordFileError(InputError):
    """A results file with a line that is not a DecisionRecord (other than a torn last line)."""


def _first_error(exc: ValidationError) -> str:
    error = exc.errors()[0]
    where = ".".join(str(p) for p in error.get("loc", ())) or "record"
    return f"{where}: {error.get('msg', 'invalid')}"


__all__ = [
    "CSV_COLUMNS",
    "TIMING_FIELDS",
    "DecisionRecord",
    "RecordFileError",
    "append_record",
    "csv_row",
    "iter_jsonl",
    "read_records",
    "write_csv",
    "write_jsonl",
]
