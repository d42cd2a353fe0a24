"""From a raw table to a typed data set: the group column, the outcome columns and their kinds.

Detection rules (stated in the report):

* Group column: ``--group``; else ``system`` (our DecisionRecord files); else a column named ``group``,
  ``condition``, ``treatment``, ``arm``, ``config``, ``configuration``, ``method`` or ``model``; else the only
  text column with 2–50 distinct values. Anything else is an error that lists the candidates.
* Outcome columns: ``--value``; else every other column that is numeric (continuous), boolean or 0/1
  (binary), or text with 2–20 distinct values (categorical). Identifier columns (``id``, ``*_id``) and free
  text are skipped and listed. A column that is mostly numbers but has a non-numeric cell is an error that
  names the line.
* DecisionRecord files (columns ``system`` and ``processing_time_s``): the outcomes are the paper's —
  processing time, detection confidence, persons detected, action recommendation (``n_actions >= 1``) and
  contextual analysis; then, from the scenes' ground truth (when the columns ``severity``, ``expected_severity``
  and ``casualties`` are there), correct severity, missed casualties (of the records of scenes with a casualty:
  not assessed high or critical) and false alarms (of the records of scenes without one: assessed high or
  critical), as the campaign's metrics define them.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Literal

import numpy as np
import numpy.typing as npt

from evaluation.stats._typing import FloatArray, IntArray
from evaluation.stats.errors import InputError
from evaluation.stats.models import SkippedColumn
from evaluation.stats.readers import MISSING_TOKENS, RawTable, read_path, read_records

TRUE_TOKENS = frozenset({"true", "yes"})
FALSE_TOKENS = frozenset({"false", "no"})
GROUP_NAMES = ("group", "condition", "treatment", "arm", "config", "configuration", "method", "model")
MAX_GROUP_LEVELS = 50
MAX_GROUPS = 100
"""The most groups ``eval stats`` compares: its pairwise tests grow with the square of the number of groups."""
MAX_CATEGORICAL_LEVELS = 20
BINARY_LEVELS = ("false", "true")

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
DECISION_RECORD_CONTINUOUS = frozenset({"processing_time_s", "detection_confidence"})
DECISION_RECORD_SKIPPED = {
    "scene_id": "identifier",
    "n_actions": "used for action_recommended (n_actions >= 1)",
    "error": "free text (records with an error are counted in the notes)",
}


@dataclass(frozen=True)
class ContinuousColumn:
    name: str
    label: str
    values: FloatArray
    """One value per row; NaN is missing."""
    unit: str | None = None
    kind: Literal["continuous"] = "continuous"


@dataclass(frozen=True)
class CategoricalColumn:
    name: str
    label: str
    codes: IntArray
    """Index into ``levels`` per row; -1 is missing."""
    levels: tuple[str, ...]
    kind: Literal["binary", "categorical"] = "categorical"

    @property
    def positive(self) -> int | None:
        return 1 if self.kind == "binary" else None


Column = ContinuousColumn | CategoricalColumn


@dataclass(frozen=True)
class Dataset:
    """Rows in groups, with typed outcome columns."""

    source: str
    group_column: str
    groups: tuple[str, ...]
    group_codes: IntArray
    columns: tuple[Column, ...]
    skipped: tuple[SkippedColumn, ...] = ()
    notes: tuple[str, ...] = ()
    schema: Literal["generic", "decision-records", "arrays"] = "generic"

    @property
    def n_rows(self) -> int:
        return int(self.group_codes.size)

    @cached_property
    def _group_rows(self) -> list[npt.NDArray[np.intp]]:
        order = np.argsort(self.group_codes, kind="stable")
        bounds = np.searchsorted(self.group_codes[order], np.arange(len(self.groups) + 1))
        return [order[bounds[g] : bounds[g + 1]] for g in range(len(self.groups))]

    def rows_of(self, group: int) -> npt.NDArray[np.intp]:
        """Row indices of group number ``group`` (in ``groups`` order)."""
        return self._group_rows[group]

    def samples(self, column: ContinuousColumn) -> tuple[list[FloatArray], list[int]]:
        """Per group: the non-missing values, and how many were missing."""
        out: list[FloatArray] = []
        missing: list[int] = []
        for g in range(len(self.groups)):
            values = column.values[self.rows_of(g)]
            keep = ~np.isnan(values)
            n_keep = int(keep.sum())
            out.append(values if n_keep == values.size else values[keep])
            missing.append(int(values.size) - n_keep)
        return out, missing

    def column(self, name: str) -> Column:
        for c in self.columns:
            if c.name == name:
                return c
        raise KeyError(name)

    @classmethod
    def from_groups(
        cls,
        groups: Mapping[str, npt.ArrayLike],
        name: str = "value",
        label: str | None = None,
        unit: str | None = None,
        source: str = "<arrays>",
    ) -> Dataset:
        """One continuous outcome given as arrays per group (NaN = missing)."""
        labels = tuple(str(g) for g in groups)
        if len(labels) < 2:
            raise InputError(f"needs at least 2 groups, got {len(labels)}", source=source)
        if len(labels) > MAX_GROUPS:
            raise InputError(_too_many_groups(), source=source)
        arrays = [np.asarray(v, dtype=np.float64).ravel() for v in groups.values()]
        for lab, arr in zip(labels, arrays, strict=True):
            if np.isinf(arr).any():
                raise InputError(f"group {lab!r} contains an infinite value", source=source, column=name)
        codes = np.repeat(np.arange(len(labels), dtype=np.int64), [a.size for a in arrays])
        values = np.concatenate(arrays)
        column = ContinuousColumn(name=name, label=label or name, values=values, unit=unit or _unit_of(name))
        return cls(source, "group", labels, codes, (column,), schema="arrays")


# --------------------------------------------------------------------------- loading


def load_dataset(
    source: str | os.PathLike[str] | Iterable[object] | Dataset,
    group: str | None = None,
    values: Sequence[str] | None = None,
    categorical: Sequence[str] = (),
) -> Dataset:
    """Read a results file or records and detect (or check) the group and outcome columns."""
    if isinstance(source, Dataset):
        return source
    if isinstance(source, str | os.PathLike):
        raw = read_path(source)
        try:
            return build_dataset(raw, group, values, categorical)
        except InputError:
            if raw.exact:
                raise
        # The fast reader's row positions may be approximate: re-read to name the exact line.
        return build_dataset(read_path(source, fast=False), group, values, categorical)
    return build_dataset(read_records(source), group, values, categorical)


def build_dataset(
    raw: RawTable, group: str | None = None, values: Sequence[str] | None = None, categorical: Sequence[str] = ()
) -> Dataset:
    if raw.n_rows == 0:
        raise InputError("no data rows", source=raw.source)
    header = raw.header
    ours = {"system", "processing_time_s"} <= set(header)
    for name in [*(values or ()), *categorical, *([group] if group else [])]:
        known = name in header or (ours and _derivable(name, header))
        if not known:
            raise InputError(f"no column {name!r}; the columns are: {', '.join(header)}", source=raw.source)
    group_name = group or _detect_group(raw, ours)
    group_labels, group_codes = _parse_groups(raw, group_name)
    if len(group_labels) < 2:
        only = f" ({group_labels[0]!r})" if group_labels else ""
        raise InputError(
            f"needs at least 2 groups to compare; column {group_name!r} has {len(group_labels)}{only}",
            source=raw.source,
        )
    if len(group_labels) == raw.n_rows and raw.n_rows > 2:
        raise InputError(
            f"column {group_name!r} has a different value on every row ({raw.n_rows} groups of one): "
            "not a group column; name the right one with --group",
            source=raw.source,
        )
    columns: list[Column] = []
    skipped: list[SkippedColumn] = []
    notes: list[str] = []
    forced = set(categorical)
    if values:
        names = list(dict.fromkeys(values))
        explicit = True
    elif ours:
        names = [n for n in DECISION_RECORD_OUTCOMES if n in header or _derivable(n, header)]
        explicit = True
        skipped.extend(
            SkippedColumn(column=c, reason=DECISION_RECORD_SKIPPED.get(c, "not one of the paper's outcomes"))
            for c in header
            if c not in names and c != group_name
        )
    else:
        names = [c for c in header if c != group_name]
        explicit = False
    names += [c for c in categorical if c not in names]
    for name in names:
        if name == group_name:
            raise InputError(f"column {name!r} is the group column; it cannot also be an outcome", source=raw.source)
        if ours and name == "action_recommended" and "action_recommended" not in header:
            columns.append(_derive_action_recommended(raw))
            continue
        if ours and name in GROUND_TRUTH_OUTCOMES and name not in header:
            columns.append(_derive_ground_truth(raw, name))
            continue
        if not explicit and _is_identifier(name):
            skipped.append(SkippedColumn(column=name, reason="identifier"))
            continue
        label, unit = DECISION_RECORD_OUTCOMES.get(name, (name, _unit_of(name))) if ours else (name, _unit_of(name))
        parsed = _parse_column(raw, name, force_categorical=name in forced, explicit=explicit or name in forced)
        if ours and name in DECISION_RECORD_CONTINUOUS and isinstance(parsed, _Parsed) and parsed.kind == "binary":
            parsed = ContinuousColumn(name=name, label=label, values=_binary_as_numbers(parsed.codes))
        if isinstance(parsed, SkippedColumn):
            skipped.append(parsed)
            continue
        if isinstance(parsed, ContinuousColumn):
            columns.append(ContinuousColumn(name=name, label=label, values=parsed.values, unit=unit))
        else:
            columns.append(
                CategoricalColumn(name=name, label=label, codes=parsed.codes, levels=parsed.levels, kind=parsed.kind)
            )
    if not columns:
        raise InputError(
            "no outcome columns to analyse"
            + (f" (skipped: {', '.join(s.column for s in skipped)})" if skipped else ""),
            source=raw.source,
        )
    if ours and "error" in header:
        notes.extend(_error_notes(raw, group_labels, group_codes))
    return Dataset(
        source=raw.source,
        group_column=group_name,
        groups=tuple(group_labels),
        group_codes=group_codes,
        columns=tuple(columns),
        skipped=tuple(skipped),
        notes=tuple(notes),
        schema="decision-records" if ours else "generic",
    )


# --------------------------------------------------------------------------- detection


def _is_identifier(name: str) -> bool:
    low = name.lower()
    return low in {"id", "index", "row"} or low.endswith(("_id", "-id", " id"))


def _unit_of(name: str) -> str | None:
    low = name.lower()
    for suffix, unit in (("_s", "s"), ("_sec", "s"), ("_seconds", "s"), ("_ms", "ms"), ("_us", "µs")):
        if low.endswith(suffix):
            return unit
    return None


def _detect_group(raw: RawTable, ours: bool) -> str:
    header = raw.header
    if ours:
        return "system"
    lowered = {h.lower(): h for h in header}
    for name in GROUP_NAMES:
        if name in lowered:
            return lowered[name]
    candidates = []
    for index, name in enumerate(header):
        column = raw.columns[index]
        if isinstance(column, np.ndarray) or _is_identifier(name):
            continue
        texts = {str(c).strip() for c in column if isinstance(c, str) and _text_kind(c) == "text"}
        if 2 <= len(texts) <= MAX_GROUP_LEVELS and len(texts) < raw.n_rows:
            candidates.append(name)
    if len(candidates) == 1:
        return candidates[0]
    if not candidates:
        raise InputError("cannot tell which column holds the groups; name it with --group", source=raw.source)
    raise InputError(
        f"several columns could hold the groups ({', '.join(candidates)}); name one with --group", source=raw.source
    )


def _parse_groups(raw: RawTable, name: str) -> tuple[list[str], IntArray]:
    index = raw.column_index(name)
    column = raw.columns[index]
    if isinstance(column, np.ndarray):
        cells: Sequence[object] = [None if math.isnan(v) else _format_number(float(v)) for v in column.tolist()]
    else:
        cells = column
    lookup: dict[str, int] = {}
    codes = np.empty(len(cells), dtype=np.int64)
    for row, cell in enumerate(cells):
        text = _cell_text(cell)
        if text is None:
            raise raw.error("empty group value", row, name)
        code = lookup.get(text)
        if code is None:
            if len(lookup) == MAX_GROUPS:
                raise raw.error(_too_many_groups(), row, name)
            code = lookup[text] = len(lookup)
        codes[row] = code
    return list(lookup), codes


def _too_many_groups() -> str:
    return (
        f"more than {MAX_GROUPS} groups: the pairwise comparisons would number in the thousands; "
        "is this the group column? (name the right one with --group, or split the file)"
    )


def _format_number(x: float) -> str:
    return str(int(x)) if x.is_integer() else repr(x)


def _cell_text(cell: object) -> str | None:
    if cell is None:
        return None
    if isinstance(cell, float) and math.isnan(cell):
        return None
    if isinstance(cell, bool):
        return "true" if cell else "false"
    if isinstance(cell, float):
        return _format_number(cell)
    text = str(cell).strip()
    return None if text.lower() in MISSING_TOKENS else text


def _text_kind(text: str) -> Literal["missing", "bool", "number", "text"]:
    low = text.strip().lower()
    if low in MISSING_TOKENS:
        return "missing"
    if low in TRUE_TOKENS or low in FALSE_TOKENS:
        return "bool"
    try:
        float(low)
    except ValueError:
        return "text"
    return "number"


# --------------------------------------------------------------------------- column parsing


@dataclass(frozen=True)
class _Parsed:
    codes: IntArray
    levels: tuple[str, ...]
    kind: Literal["binary", "categorical"]


def _parse_column(
    raw: RawTable, name: str, *, force_categorical: bool, explicit: bool
) -> ContinuousColumn | _Parsed | SkippedColumn:
    column = raw.columns[raw.column_index(name)]
    if isinstance(column, np.ndarray):
        numbers: FloatArray = column
    elif raw.positional and all(isinstance(c, str) for c in column[:1]):
        # CSV text: one C-level conversion when every cell is a number; anything else takes the slow path.
        try:
            numbers = np.asarray(column, dtype=np.float64)
        except (ValueError, TypeError):
            return _parse_mixed(raw, name, column, force_categorical=force_categorical, explicit=explicit)
    else:
        return _parse_mixed(raw, name, column, force_categorical=force_categorical, explicit=explicit)
    bad = np.flatnonzero(np.isinf(numbers))
    if bad.size:
        row = int(bad[0])
        cell = column[row]
        raise raw.error(f"non-finite value {cell!r}", row, name)
    return _numeric_kind(numbers, name, force_categorical)


def _numeric_kind(
    numbers: FloatArray, name: str, force_categorical: bool
) -> ContinuousColumn | _Parsed | SkippedColumn:
    present = numbers[~np.isnan(numbers)]
    if present.size == 0:
        return SkippedColumn(column=name, reason="no values")
    distinct = np.unique(present)
    if force_categorical:
        levels = tuple(_format_number(float(v)) for v in distinct)
        codes = np.where(np.isnan(numbers), -1, np.searchsorted(distinct, np.nan_to_num(numbers, nan=distinct[0])))
        return _Parsed(codes.astype(np.int64), levels, "categorical")
    if np.isin(distinct, (0.0, 1.0)).all():
        codes = np.where(np.isnan(numbers), -1, numbers == 1.0).astype(np.int64)
        return _Parsed(codes, BINARY_LEVELS, "binary")
    return ContinuousColumn(name=name, label=name, values=numbers)


def _parse_mixed(
    raw: RawTable, name: str, cells: Sequence[object], *, force_categorical: bool, explicit: bool
) -> ContinuousColumn | _Parsed | SkippedColumn:
    n = len(cells)
    numbers = np.full(n, np.nan)
    bools = np.full(n, -1, dtype=np.int64)
    texts: list[str | None] = [None] * n
    n_number = n_bool = n_text = 0
    first_text = first_bool = -1
    for row, cell in enumerate(cells):
        if cell is None:
            continue
        if isinstance(cell, bool):
            bools[row] = int(cell)
            texts[row] = "true" if cell else "false"
            n_bool += 1
            if first_bool < 0:
                first_bool = row
            continue
        if isinstance(cell, int | float):
            value = float(cell)
            if math.isnan(value):
                continue
            if math.isinf(value):
                raise _cell_error(raw, name, row, f"non-finite value {cell!r}")
            numbers[row] = value
            texts[row] = _format_number(value)
            n_number += 1
            continue
        if not isinstance(cell, str):
            if explicit:
                raise _cell_error(raw, name, row, f"nested value of type {type(cell).__name__}")
            return SkippedColumn(column=name, reason="nested values (objects or lists)")
        text = cell.strip()
        kind = _text_kind(text)
        if kind == "missing":
            continue
        texts[row] = text
        if kind == "bool":
            bools[row] = int(text.lower() in TRUE_TOKENS)
            n_bool += 1
            if first_bool < 0:
                first_bool = row
        elif kind == "number":
            value = float(text)
            if math.isinf(value):
                raise _cell_error(raw, name, row, f"non-finite value {text!r}")
            if math.isnan(value):
                texts[row] = None
                continue
            numbers[row] = value
            n_number += 1
        else:
            n_text += 1
            if first_text < 0:
                first_text = row
    if n_number + n_bool + n_text == 0:
        if explicit:
            raise InputError("the column has no values", source=raw.source, column=name)
        return SkippedColumn(column=name, reason="no values")
    if force_categorical or n_text > n_number + n_bool:
        return _categorical(raw, name, texts, explicit)
    if n_text:
        raise _cell_error(raw, name, first_text, f"non-numeric value {texts[first_text]!r} in a numeric column")
    if n_bool and n_number:
        present = numbers[~np.isnan(numbers)]
        if not np.isin(present, (0.0, 1.0)).all():
            raise _cell_error(raw, name, first_bool, f"boolean value {texts[first_bool]!r} in a numeric column")
        combined = np.where(bools >= 0, bools, np.where(np.isnan(numbers), -1, numbers == 1.0)).astype(np.int64)
        return _Parsed(combined, BINARY_LEVELS, "binary")
    if n_bool:
        return _Parsed(bools, BINARY_LEVELS, "binary")
    return _numeric_kind(numbers, name, False)


def _categorical(raw: RawTable, name: str, texts: Sequence[str | None], explicit: bool) -> _Parsed | SkippedColumn:
    lookup: dict[str, int] = {}
    codes = np.empty(len(texts), dtype=np.int64)
    for row, text in enumerate(texts):
        if text is None:
            codes[row] = -1
            continue
        code = lookup.get(text)
        if code is None:
            if len(lookup) == MAX_GROUPS:
                raise raw.error(_too_many_groups(), row, name)
            code = lookup[text] = len(lookup)
        codes[row] = code
    n_levels = len(lookup)
    if n_levels > MAX_CATEGORICAL_LEVELS or n_levels >= raw.n_rows:
        message = f"{n_levels} distinct text values: neither numeric nor categorical (at most {MAX_CATEGORICAL_LEVELS})"
        if explicit:
            raise InputError(message, source=raw.source, column=name)
        return SkippedColumn(column=name, reason=f"free text ({n_levels} distinct values)")
    if n_levels < 2 and not explicit:
        return SkippedColumn(column=name, reason="a single value")
    return _Parsed(codes, tuple(lookup), "categorical")


def _binary_as_numbers(codes: IntArray) -> FloatArray:
    """A 0/1 column that is known to be continuous (e.g. confidences that happen to be 0 or 1)."""
    return np.where(codes < 0, np.nan, codes.astype(np.float64))


def _cell_error(raw: RawTable, name: str, row: int, message: str) -> InputError:
    return raw.error(message, row, name)


def _derive_action_recommended(raw: RawTable) -> CategoricalColumn:
    parsed = _parse_column(raw, "n_actions", force_categorical=False, explicit=True)
    if isinstance(parsed, ContinuousColumn):
        counts = parsed.values
        codes = np.where(np.isnan(counts), -1, counts >= 1.0).astype(np.int64)
    elif isinstance(parsed, _Parsed) and parsed.kind == "binary":
        codes = parsed.codes
    else:
        raise InputError("n_actions must be a count", source=raw.source, column="n_actions")
    label = DECISION_RECORD_OUTCOMES["action_recommended"][0]
    return CategoricalColumn(name="action_recommended", label=label, codes=codes, levels=BINARY_LEVELS, kind="binary")


def _derivable(name: str, header: Sequence[str]) -> bool:
    if name == "action_recommended":
        return "n_actions" in header
    return name in GROUND_TRUTH_OUTCOMES and all(c in header for c in GROUND_TRUTH_COLUMNS)


def _derive_ground_truth(raw: RawTable, name: str) -> CategoricalColumn:
    """Correct severity, a missed casualty or a false alarm per record (see the module docs); missing where the
    record does not count (a missed casualty in a scene without one), or where the ground truth is missing."""
    severity = [_cell_text(c) for c in _cells(raw, "severity")]
    expected = [_cell_text(c) for c in _cells(raw, "expected_severity")]
    casualties = _parse_column(raw, "casualties", force_categorical=False, explicit=True)
    if isinstance(casualties, ContinuousColumn):
        counts = casualties.values
    elif isinstance(casualties, _Parsed) and casualties.kind == "binary":
        counts = _binary_as_numbers(casualties.codes)
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


def _cells(raw: RawTable, name: str) -> Sequence[object]:
    column = raw.columns[raw.column_index(name)]
    if isinstance(column, np.ndarray):
        return [None if math.isnan(v) else _format_number(float(v)) for v in column.tolist()]
    return column


def _error_notes(raw: RawTable, groups: Sequence[str], codes: IntArray) -> list[str]:
    column = raw.columns[raw.column_index("error")]
    if isinstance(column, np.ndarray):
        return []
    has_error = np.array([_cell_text(c) is not None for c in column], dtype=bool)
    if not has_error.any():
        return []
    counts = np.bincount(codes[has_error], minlength=len(groups))
    detail = ", ".join(f"{g}: {int(c)}" for g, c in zip(groups, counts, strict=True) if c)
    return [f"records with an error (kept in every denominator): {detail}"]


__all__ = [
    "DECISION_RECORD_OUTCOMES",
    "CategoricalColumn",
    "Column",
    "ContinuousColumn",
    "Dataset",
    "build_dataset",
    "load_dataset",
]
