"""Typed columns, and the cells of a raw table read into them: numbers, booleans, categories, missing values.

A column that is mostly numbers but has a non-numeric cell is an error naming the cell; a text column with more
than :data:`MAX_CATEGORICAL_LEVELS` distinct values is free text.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from evaluation.stats._typing import FloatArray, IntArray
from evaluation.stats.errors import InputError
from evaluation.stats.models import SkippedColumn
from evaluation.stats.readers import MISSING_TOKENS, HugeInteger, RawTable

TRUE_TOKENS = frozenset({"true", "yes"})
FALSE_TOKENS = frozenset({"false", "no"})
MAX_GROUPS = 100
"""The most groups ``eval stats`` compares: its pairwise tests grow with the square of the number of groups."""
MAX_CATEGORICAL_LEVELS = 20
BINARY_LEVELS = ("false", "true")


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


def too_many_groups() -> str:
    return (
        f"more than {MAX_GROUPS} groups: the pairwise comparisons would number in the thousands; "
        "is this the group column? (name the right one with --group, or split the file)"
    )


def format_number(x: float) -> str:
    return str(int(x)) if x.is_integer() else repr(x)


def cell_text(cell: object) -> str | None:
    if cell is None:
        return None
    if isinstance(cell, float) and math.isnan(cell):
        return None
    if isinstance(cell, bool):
        return "true" if cell else "false"
    if isinstance(cell, float):
        return format_number(cell)
    text = str(cell).strip()
    return None if text.lower() in MISSING_TOKENS else text


def text_kind(text: str) -> Literal["missing", "bool", "number", "text"]:
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


@dataclass(frozen=True)
class Parsed:
    codes: IntArray
    levels: tuple[str, ...]
    kind: Literal["binary", "categorical"]


def parse_column(
    raw: RawTable, name: str, *, force_categorical: bool, explicit: bool
) -> ContinuousColumn | Parsed | SkippedColumn:
    column = raw.columns[raw.column_index(name)]
    if isinstance(column, np.ndarray):
        numbers: FloatArray = column
    elif raw.positional and all(isinstance(c, str) for c in column[:1]):
        # CSV text: one C-level conversion when every cell is a number; anything else takes the slow path.
        try:
            numbers = np.asarray(column, dtype=np.float64)
        except (ValueError, TypeError):
            return parse_mixed(raw, name, column, force_categorical=force_categorical, explicit=explicit)
    else:
        return parse_mixed(raw, name, column, force_categorical=force_categorical, explicit=explicit)
    bad = np.flatnonzero(np.isinf(numbers))
    if bad.size:
        row = int(bad[0])
        cell = column[row]
        raise raw.error(f"non-finite value {cell!r}", row, name)
    return numeric_kind(numbers, name, force_categorical)


def numeric_kind(numbers: FloatArray, name: str, force_categorical: bool) -> ContinuousColumn | Parsed | SkippedColumn:
    present = numbers[~np.isnan(numbers)]
    if present.size == 0:
        return SkippedColumn(column=name, reason="no values")
    distinct = np.unique(present)
    if force_categorical:
        levels = tuple(format_number(float(v)) for v in distinct)
        codes = np.where(np.isnan(numbers), -1, np.searchsorted(distinct, np.nan_to_num(numbers, nan=distinct[0])))
        return Parsed(codes.astype(np.int64), levels, "categorical")
    if np.isin(distinct, (0.0, 1.0)).all():
        codes = np.where(np.isnan(numbers), -1, numbers == 1.0).astype(np.int64)
        return Parsed(codes, BINARY_LEVELS, "binary")
    return ContinuousColumn(name=name, label=name, values=numbers)


def parse_mixed(
    raw: RawTable, name: str, cells: Sequence[object], *, force_categorical: bool, explicit: bool
) -> ContinuousColumn | Parsed | SkippedColumn:
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
        if isinstance(cell, HugeInteger):
            raise cell_error(raw, name, row, f"an integer of {len(cell.digits)} digits is too large for a number")
        if isinstance(cell, int | float):
            try:
                value = float(cell)
            except OverflowError:
                raise cell_error(raw, name, row, "an integer too large for a number (above 1.8e308)") from None
            if math.isnan(value):
                continue
            if math.isinf(value):
                raise cell_error(raw, name, row, f"non-finite value {cell!r}")
            numbers[row] = value
            texts[row] = format_number(value)
            n_number += 1
            continue
        if not isinstance(cell, str):
            if explicit:
                raise cell_error(raw, name, row, f"nested value of type {type(cell).__name__}")
            return SkippedColumn(column=name, reason="nested values (objects or lists)")
        text = cell.strip()
        kind = text_kind(text)
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
                raise cell_error(raw, name, row, f"non-finite value {text!r}")
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
        return categorical(raw, name, texts, explicit)
    if n_text:
        raise cell_error(raw, name, first_text, f"non-numeric value {texts[first_text]!r} in a numeric column")
    if n_bool and n_number:
        present = numbers[~np.isnan(numbers)]
        if not np.isin(present, (0.0, 1.0)).all():
            raise cell_error(raw, name, first_bool, f"boolean value {texts[first_bool]!r} in a numeric column")
        combined = np.where(bools >= 0, bools, np.where(np.isnan(numbers), -1, numbers == 1.0)).astype(np.int64)
        return Parsed(combined, BINARY_LEVELS, "binary")
    if n_bool:
        return Parsed(bools, BINARY_LEVELS, "binary")
    return numeric_kind(numbers, name, False)


def level_code(lookup: dict[str, int], text: str, raw: RawTable, row: int, name: str) -> int:
    """The code of ``text`` among the levels seen so far, a new level taking the next code; more than
    :data:`MAX_GROUPS` levels is an error naming the cell."""
    code = lookup.get(text)
    if code is None:
        if len(lookup) == MAX_GROUPS:
            raise raw.error(too_many_groups(), row, name)
        code = lookup[text] = len(lookup)
    return code


def categorical(raw: RawTable, name: str, texts: Sequence[str | None], explicit: bool) -> Parsed | SkippedColumn:
    lookup: dict[str, int] = {}
    codes = np.empty(len(texts), dtype=np.int64)
    for row, text in enumerate(texts):
        # Free text is told by its count of levels, so an outcome column is never held to the groups' limit.
        codes[row] = -1 if text is None else lookup.setdefault(text, len(lookup))
    n_levels = len(lookup)
    if n_levels > MAX_CATEGORICAL_LEVELS or n_levels >= raw.n_rows:
        message = f"{n_levels} distinct text values: neither numeric nor categorical (at most {MAX_CATEGORICAL_LEVELS})"
        if explicit:
            raise InputError(message, source=raw.source, column=name)
        return SkippedColumn(column=name, reason=f"free text ({n_levels} distinct values)")
    if n_levels < 2 and not explicit:
        return SkippedColumn(column=name, reason="a single value")
    return Parsed(codes, tuple(lookup), "categorical")


def binary_as_numbers(codes: IntArray) -> FloatArray:
    """A 0/1 column that is known to be continuous (e.g. confidences that happen to be 0 or 1)."""
    return np.where(codes < 0, np.nan, codes.astype(np.float64))


def cell_error(raw: RawTable, name: str, row: int, message: str) -> InputError:
    return raw.error(message, row, name)


def cells(raw: RawTable, name: str) -> Sequence[object]:
    column = raw.columns[raw.column_index(name)]
    if isinstance(column, np.ndarray):
        return [None if math.isnan(v) else format_number(float(v)) for v in column.tolist()]
    return column


__all__ = [
    "BINARY_LEVELS",
    "MAX_CATEGORICAL_LEVELS",
    "MAX_GROUPS",
    "CategoricalColumn",
    "Column",
    "ContinuousColumn",
    "Parsed",
    "binary_as_numbers",
    "cell_text",
    "cells",
    "format_number",
    "level_code",
    "parse_column",
    "text_kind",
    "too_many_groups",
]
