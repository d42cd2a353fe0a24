"""Reading results into a raw table: CSV/TSV, JSON (a list of objects), JSON Lines, or Python records
(mappings, pydantic models, dataclasses). Cells stay untyped here; :mod:`evaluation.stats.dataset` parses them.

Large CSV files are read with pandas' C parser when pandas is importable (statsmodels depends on it); the
result is only used if it parses cleanly, otherwise the file is re-read with the :mod:`csv` module, which
names the exact line of any problem. pandas is never required.
"""

from __future__ import annotations

import csv
import dataclasses
import importlib
import json
import os
from array import array
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from agentic_core.contracts import json_depth as bounded_json
from agentic_core.contracts.input_files import InputFileError, check_input_file
from evaluation.stats._typing import FloatArray
from evaluation.stats.errors import InputError

#: Cell texts read as a missing value (compared case-insensitively, after stripping blanks). Not ``none``: it is
#: a category of its own (a severity of ``none``), and JSON's null arrives as a missing value already.
MISSING_TOKENS = frozenset({"", "na", "n/a", "nan", "null", "-"})
#: Files at least this large are tried with pandas' parser first.
FAST_CSV_BYTES = 4 * 1024 * 1024

Cells = Sequence[object]
#: More digits than the largest double has (1.8e308 has 309): such a JSON integer is kept as its text.
MAX_INTEGER_DIGITS = 400


@dataclass(frozen=True)
class HugeInteger:
    """A JSON integer too long to be a number here (Python refuses to read more than 4300 digits; no double holds
    more than 309): kept as its digits so the cell, not the parser, is named in the error."""

    digits: str

    def __str__(self) -> str:
        return self.digits


def _json_int(text: str) -> int | HugeInteger:
    return int(text) if len(text) <= MAX_INTEGER_DIGITS else HugeInteger(text)


@dataclass
class RawTable:
    """Columns of cells. A column is either a list of cells (str, numbers, bools, None) or, from the fast
    path, an already numeric float array (NaN = missing)."""

    source: str
    header: list[str]
    columns: list[Cells | FloatArray]
    n_rows: int
    location_kind: Literal["line", "record"]
    locations: Sequence[int] | None = None
    """Line (or record) number of each row; ``None`` means row i is at ``first_location + i``."""
    first_location: int = 1
    exact: bool = True
    """False for the fast path, whose row positions may be approximate; errors then trigger a re-read."""
    positional: bool = False
    """True when columns have positions the user can count (CSV), so errors name the column number."""

    def column_index(self, name: str) -> int:
        return self.header.index(name)

    def error(self, message: str, row: int | None = None, column: str | None = None) -> InputError:
        """An :class:`InputError` that names this source, the row's line or record, and the column."""
        line = record = None
        if row is not None:
            location = self.locations[row] if self.locations is not None else self.first_location + row
            if self.location_kind == "line":
                line = location
            else:
                record = location
        column_index = None
        if column is not None and self.positional and column in self.header:
            column_index = self.header.index(column) + 1
        return InputError(
            message, source=self.source, line=line, record=record, column=column, column_index=column_index
        )


def read_path(path: str | os.PathLike[str], *, fast: bool = True) -> RawTable:
    """Read a results file; the format follows the suffix (.csv, .tsv, .json, .jsonl/.ndjson) or the content.
    ``fast=False`` never uses the pandas reader (exact line numbers in every error)."""
    p = Path(path)
    source = str(path)
    if not p.exists():
        raise InputError("no such file", source=source)
    if p.is_dir():
        raise InputError("is a directory, not a results file", source=source)
    suffix = p.suffix.lower()
    try:
        check_input_file(p, "results file")
        if suffix in {".jsonl", ".ndjson"}:
            return _read_jsonl(p, source)
        if suffix == ".json":
            return _read_json(p, source)
        if suffix not in {".csv", ".tsv", ".txt"}:
            with p.open("r", encoding="utf-8-sig") as fh:
                head = fh.read(1).lstrip() or fh.read(4096).lstrip()[:1]
            if head in {"[", "{"}:
                return _read_json_any(p, source)
        return _read_csv(p, source, fast)
    except UnicodeDecodeError as exc:
        raise InputError(f"not UTF-8 text ({exc.reason} at byte {exc.start})", source=source) from None
    except InputFileError as exc:
        raise InputError(exc.reason, source=source) from None
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc.strerror or exc}", source=source) from None


def read_records(records: Iterable[object], source: str = "<records>") -> RawTable:
    """Rows from Python objects: mappings, pydantic models (``model_dump``), dataclasses or plain objects."""
    rows: list[Mapping[str, Any]] = []
    for index, record in enumerate(records, start=1):
        rows.append(_as_mapping(record, source, index))
    return _from_mappings(rows, source, "record", None, 1)


def _as_mapping(record: object, source: str, index: int) -> Mapping[str, Any]:
    if isinstance(record, Mapping):
        return record
    dump = getattr(record, "model_dump", None)
    if callable(dump):
        result = dump()
        if isinstance(result, Mapping):
            return result
    if dataclasses.is_dataclass(record) and not isinstance(record, type):
        return dataclasses.asdict(record)
    if hasattr(record, "__dict__"):
        return vars(record)
    raise InputError(f"expected an object with named fields, got {type(record).__name__}", source=source, record=index)


def _from_mappings(
    rows: Sequence[Mapping[str, Any]],
    source: str,
    kind: Literal["line", "record"],
    locations: Sequence[int] | None,
    first: int,
) -> RawTable:
    header: list[str] = []
    seen: set[str] = set()
    for row in rows:
        for key in row:
            if key not in seen:
                seen.add(key)
                header.append(str(key))
    columns: list[Cells | FloatArray] = [[row.get(name) for row in rows] for name in header]
    return RawTable(source, header, columns, len(rows), kind, locations, first)


def _read_json_any(p: Path, source: str) -> RawTable:
    try:
        return _read_json(p, source)
    except InputError:
        return _read_jsonl(p, source)


def _read_json(p: Path, source: str) -> RawTable:
    text = p.read_text(encoding="utf-8-sig")
    try:
        data = bounded_json.loads(text, parse_int=_json_int)
    except json.JSONDecodeError as exc:
        raise InputError(f"invalid JSON: {exc.msg}", source=source, line=exc.lineno, col=exc.colno) from None
    except bounded_json.JsonTooDeep as exc:
        raise InputError(str(exc), source=source) from None
    if isinstance(data, Mapping):
        for key in ("records", "results", "rows", "data"):
            if isinstance(data.get(key), list):
                data = data[key]
                break
    if not isinstance(data, list):
        raise InputError("expected a JSON list of objects (or an object with a 'records' list)", source=source)
    for index, row in enumerate(data, start=1):
        if not isinstance(row, Mapping):
            raise InputError(f"expected a JSON object, got {type(row).__name__}", source=source, record=index)
    return _from_mappings(data, source, "record", None, 1)


def _read_jsonl(p: Path, source: str) -> RawTable:
    rows: list[Mapping[str, Any]] = []
    lines: list[int] = []
    with p.open("r", encoding="utf-8-sig") as fh:
        for number, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            try:
                row = bounded_json.loads(line, parse_int=_json_int)
            except json.JSONDecodeError as exc:
                raise InputError(f"invalid JSON: {exc.msg}", source=source, line=number, col=exc.colno) from None
            except bounded_json.JsonTooDeep as exc:
                raise InputError(str(exc), source=source, line=number) from None
            if not isinstance(row, Mapping):
                raise InputError(f"expected a JSON object, got {type(row).__name__}", source=source, line=number)
            rows.append(row)
            lines.append(number)
    return _from_mappings(rows, source, "line", lines, 1)


def _sniff_delimiter(p: Path, first_line: str) -> str:
    if p.suffix.lower() == ".tsv":
        return "\t"
    counts = {d: first_line.count(d) for d in (",", "\t", ";")}
    best = max(counts, key=lambda d: counts[d])
    return best if counts[best] > 0 else ","


def _check_header(header: list[str], source: str) -> list[str]:
    names = [h.strip() for h in header]
    seen: set[str] = set()
    for index, name in enumerate(names, start=1):
        if not name:
            raise InputError("empty column name in the header", source=source, line=1, column="", column_index=index)
        if name in seen:
            raise InputError("duplicate column name", source=source, line=1, column=name, column_index=index)
        seen.add(name)
    return names


def _read_csv(p: Path, source: str, fast: bool) -> RawTable:
    with p.open("r", encoding="utf-8-sig", newline="") as fh:
        first_line = fh.readline()
    if not first_line.strip():
        raise InputError("empty file (no header line)", source=source, line=1)
    delimiter = _sniff_delimiter(p, first_line)
    if fast and p.stat().st_size >= FAST_CSV_BYTES:
        table = _read_csv_fast(p, source, delimiter, next(csv.reader([first_line], delimiter=delimiter), []))
        if table is not None:
            return table
    return _read_csv_slow(p, source, delimiter)


def _read_csv_slow(p: Path, source: str, delimiter: str) -> RawTable:
    with p.open("r", encoding="utf-8-sig", newline="") as fh:
        reader = csv.reader(fh, delimiter=delimiter, strict=True)
        try:
            header = _check_header(next(reader), source)
            width = len(header)
            columns: list[list[str]] = [[] for _ in header]
            lines = array("q")
            chunk: list[list[str]] = []
            previous = reader.line_num
            for row in reader:
                start, previous = previous + 1, reader.line_num  # a quoted cell may span lines: where it starts
                if not row or (len(row) == 1 and not row[0].strip() and width > 1):
                    continue
                if len(row) != width:
                    raise InputError(
                        f"expected {width} fields (as in the header), found {len(row)}", source=source, line=start
                    )
                chunk.append(row)
                lines.append(start)
                if len(chunk) >= 65536:
                    _flush(columns, chunk)
            _flush(columns, chunk)
        except csv.Error as exc:
            raise InputError(f"malformed CSV: {exc}", source=source, line=reader.line_num) from None
    return RawTable(source, header, list(columns), len(lines), "line", lines, 2, positional=True)


def _flush(columns: list[list[str]], chunk: list[list[str]]) -> None:
    if chunk:
        for column, values in zip(columns, zip(*chunk, strict=True), strict=True):
            column.extend(values)
        chunk.clear()


def _read_csv_fast(p: Path, source: str, delimiter: str, raw_header: list[str]) -> RawTable | None:
    """pandas' parser for large files; ``None`` whenever anything is unusual (the slow path then decides)."""
    try:
        pd: Any = importlib.import_module("pandas")
    except ImportError:  # pragma: no cover - pandas comes with statsmodels
        return None
    variants = sorted({t for token in MISSING_TOKENS for t in (token, token.upper(), token.capitalize())})
    try:
        frame = pd.read_csv(
            p,
            sep=delimiter,
            encoding="utf-8-sig",
            keep_default_na=False,
            na_values=variants,
            skip_blank_lines=False,
            engine="c",
        )
    except Exception:
        return None
    header = [str(c) for c in frame.columns]
    if header != raw_header:  # pandas renames duplicates and blanks; the slow path reports them
        return None
    try:
        header = _check_header(header, source)
    except InputError:
        return None
    if frame.isna().all(axis=1).any():  # blank lines: row numbers would shift; let the slow path handle them
        return None
    columns: list[Cells | FloatArray] = []
    for name in frame.columns:
        series = frame[name]
        kind = series.dtype.kind
        if kind in "fiu":
            columns.append(series.to_numpy(dtype=np.float64, na_value=np.nan))
        elif kind == "b":
            columns.append(series.to_numpy(dtype=object).tolist())
        else:
            columns.append([None if v is None or v is pd.NA or v != v else str(v) for v in series.tolist()])
    return RawTable(source, header, columns, len(frame), "line", None, 2, exact=False, positional=True)


__all__ = [
    "FAST_CSV_BYTES",
    "MAX_INTEGER_DIGITS",
    "MISSING_TOKENS",
    "HugeInteger",
    "RawTable",
    "read_path",
    "read_records",
]
