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
from evaluation.stats.columns import (
    MAX_GROUPS,
    CategoricalColumn,
    Column,
    ContinuousColumn,
    Parsed,
    binary_as_numbers,
    cell_text,
    format_number,
    level_code,
    parse_column,
    text_kind,
    too_many_groups,
)
from evaluation.stats.derived import (
    DECISION_RECORD_OUTCOMES,
    GROUND_TRUTH_OUTCOMES,
    derivable,
    derive_action_recommended,
    derive_ground_truth,
    error_notes,
)
from evaluation.stats.errors import InputError
from evaluation.stats.models import SkippedColumn
from evaluation.stats.readers import RawTable, read_path, read_records

GROUP_NAMES = ("group", "condition", "treatment", "arm", "config", "configuration", "method", "model")
MAX_GROUP_LEVELS = 50

DECISION_RECORD_CONTINUOUS = frozenset({"processing_time_s", "detection_confidence"})
DECISION_RECORD_SKIPPED = {
    "scene_id": "identifier",
    "n_actions": "used for action_recommended (n_actions >= 1)",
    "error": "free text (records with an error are counted in the notes)",
}


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
            raise InputError(too_many_groups(), source=source)
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
    values = column_names(values, header, ours) if values else values
    categorical = column_names(categorical, header, ours)
    for name in [*(values or ()), *categorical, *([group] if group else [])]:
        known = name in header or (ours and derivable(name, header))
        if not known:
            listing = ", ".join(repr(h) for h in header)
            raise InputError(f"no column {name!r}; the columns are: {listing}", source=raw.source)
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
        names = [n for n in DECISION_RECORD_OUTCOMES if n in header or derivable(n, header)]
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
            columns.append(derive_action_recommended(raw))
            continue
        if ours and name in GROUND_TRUTH_OUTCOMES and name not in header:
            columns.append(derive_ground_truth(raw, name))
            continue
        if not explicit and _is_identifier(name):
            skipped.append(SkippedColumn(column=name, reason="identifier"))
            continue
        label, unit = DECISION_RECORD_OUTCOMES.get(name, (name, _unit_of(name))) if ours else (name, _unit_of(name))
        parsed = parse_column(raw, name, force_categorical=name in forced, explicit=explicit or name in forced)
        if ours and name in DECISION_RECORD_CONTINUOUS and isinstance(parsed, Parsed) and parsed.kind == "binary":
            parsed = ContinuousColumn(name=name, label=label, values=binary_as_numbers(parsed.codes))
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
        notes.extend(error_notes(raw, group_labels, group_codes))
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


def column_names(items: Sequence[str], header: Sequence[str], ours: bool = False) -> list[str]:
    """Column names as given (``--value "a,b"`` names two): a column's own name wins, commas and all; the rest
    is split at commas, each piece the longest run of pieces that names a column.

    >>> column_names(["time, s", "a,b", "time, s,a"], ["group", "time, s", "a", "b"])
    ['time, s', 'a', 'b', 'time, s', 'a']
    """

    def known(name: str) -> bool:
        return name in header or (ours and derivable(name, header))

    out: list[str] = []
    for item in items:
        parts = item.split(",")
        start = 0
        while start < len(parts):
            end = next(
                (e for e in range(len(parts), start + 1, -1) if known(",".join(parts[start:e]).strip())), start + 1
            )
            out.append(",".join(parts[start:end]).strip())
            start = end
    return [n for n in out if n]


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
        texts = {str(c).strip() for c in column if isinstance(c, str) and text_kind(c) == "text"}
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
        cells: Sequence[object] = [None if math.isnan(v) else format_number(float(v)) for v in column.tolist()]
    else:
        cells = column
    lookup: dict[str, int] = {}
    codes = np.empty(len(cells), dtype=np.int64)
    for row, cell in enumerate(cells):
        text = cell_text(cell)
        if text is None:
            raise raw.error("empty group value", row, name)
        codes[row] = level_code(lookup, text, raw, row, name)
    return list(lookup), codes


__all__ = [
    "DECISION_RECORD_OUTCOMES",
    "CategoricalColumn",
    "Column",
    "ContinuousColumn",
    "Dataset",
    "build_dataset",
    "column_names",
    "load_dataset",
]
