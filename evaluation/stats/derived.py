"""The outcomes of DecisionRecord files that are computed, not read: action recommended (``n_actions >= 1``) and,
from the scenes' ground truth, correct severity, missed casualties and false alarms (as the campaign's metrics
define them); and the note on records with an error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from evaluation.stats._typing import IntArray
from evaluation.stats.columns import (
    BINARY_LEVELS,
    CategoricalColumn,
    ContinuousColumn,
    Parsed,
    binary_as_numbers,
    cell_text,
    cells,
    parse_column,
)
from evaluation.stats.errors import InputError
from evaluation.stats.readers import RawTable

#: The paper's outcomes, in the order of its Table 2, for DecisionRecord files: column -> (label, unit).
DECISION_RECORD_OUTCOMES: dict[str, tuple[str, str | None]] = {
    "processing_time_s": ("Processing Time", "s"),
    "detection_confidence": ("Detection Confidence", None),
    "person_detected": ("Persons Detected", None),
    "action_recommended": ("Action Recommendation", None),
    "contextual": ("Contextual Analysis", None),
    "correct_severity": ("Correct Severity", None),
    "missed_casualty": ("Missed Casualties", None),
    "false_alarm": ("False Alarms", None),
}
GROUND_TRUTH_OUTCOMES = frozenset({"correct_severity", "missed_casualty", "false_alarm"})
GROUND_TRUTH_COLUMNS = ("severity", "expected_severity", "casualties")
ALARM_LEVELS = frozenset({"high", "critical"})


def derive_action_recommended(raw: RawTable) -> CategoricalColumn:
    parsed = parse_column(raw, "n_actions", force_categorical=False, explicit=True)
    if isinstance(parsed, ContinuousColumn):
        counts = parsed.values
        codes = np.where(np.isnan(counts), -1, counts >= 1.0).astype(np.int64)
    elif isinstance(parsed, Parsed) and parsed.kind == "binary":
        codes = parsed.codes
    else:
        raise InputError("n_actions must be a count", source=raw.source, column="n_actions")
    label = DECISION_RECORD_OUTCOMES["action_recommended"][0]
    return CategoricalColumn(name="action_recommended", label=label, codes=codes, levels=BINARY_LEVELS, kind="binary")


def derivable(name: str, header: Sequence[str]) -> bool:
    if name == "action_recommended":
        return "n_actions" in header
    return name in GROUND_TRUTH_OUTCOMES and all(c in header for c in GROUND_TRUTH_COLUMNS)


def derive_ground_truth(raw: RawTable, name: str) -> CategoricalColumn:
    """Correct severity, a missed casualty or a false alarm per record (see the module docs); missing where the
    record does not count (a missed casualty in a scene without one), or where the ground truth is missing."""
    severity = [cell_text(c) for c in cells(raw, "severity")]
    expected = [cell_text(c) for c in cells(raw, "expected_severity")]
    casualties = parse_column(raw, "casualties", force_categorical=False, explicit=True)
    if isinstance(casualties, ContinuousColumn):
        counts = casualties.values
    elif isinstance(casualties, Parsed) and casualties.kind == "binary":
        counts = binary_as_numbers(casualties.codes)
    else:
        raise InputError("casualties must be a count", source=raw.source, column="casualties")
    codes = np.full(raw.n_rows, -1, dtype=np.int64)
    for row in range(raw.n_rows):
        alarm = severity[row] in ALARM_LEVELS
        if name == "correct_severity":
            if expected[row] is not None:
                codes[row] = int(severity[row] == expected[row])
        elif not math.isnan(counts[row]):
            hit = counts[row] > 0
            if name == "missed_casualty" and hit:
                codes[row] = int(not alarm)
            elif name == "false_alarm" and not hit:
                codes[row] = int(alarm)
    label = DECISION_RECORD_OUTCOMES[name][0]
    return CategoricalColumn(name=name, label=label, codes=codes, levels=BINARY_LEVELS, kind="binary")


def error_notes(raw: RawTable, groups: Sequence[str], codes: IntArray) -> list[str]:
    column = raw.columns[raw.column_index("error")]
    if isinstance(column, np.ndarray):
        return []
    has_error = np.array([cell_text(c) is not None for c in column], dtype=bool)
    if not has_error.any():
        return []
    counts = np.bincount(codes[has_error], minlength=len(groups))
    detail = ", ".join(f"{g}: {int(c)}" for g, c in zip(groups, counts, strict=True) if c)
    return [f"records with an error (kept in every denominator): {detail}"]


__all__ = [
    "DECISION_RECORD_OUTCOMES",
    "GROUND_TRUTH_OUTCOMES",
    "derivable",
    "derive_action_recommended",
    "derive_ground_truth",
    "error_notes",
]
