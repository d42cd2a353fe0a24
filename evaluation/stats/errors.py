"""The one error type for a user's bad input: a :class:`ProblemsError` whose one located problem names the file,
the line and column (or the record), and the field.

>>> print(InputError("non-numeric value 'fast'", source="results.csv", line=12, column="time_s", column_index=3))
results.csv:12:3: column 'time_s': non-numeric value 'fast'
>>> print(InputError("expected a JSON object, got list", source="runs.json", record=4))
runs.json: record 4: expected a JSON object, got list
"""

from __future__ import annotations

from agentic_core.contracts.problems import LocatedProblem, ProblemsError


class InputError(ProblemsError):
    """Bad input: a missing or unreadable file, an unknown column, a non-numeric value, too few groups.

    ``str(error)`` reads ``results.csv:12:3: column 'processing_time_s': non-numeric value 'fast'``; the parts are
    kept too (``source``, ``line``, ``record``, ``column``, ``column_index``, ``message``). ``col`` places a
    problem that is not a named column's, such as a JSON syntax error, on its line.
    """

    def __init__(
        self,
        message: str,
        *,
        source: str | None = None,
        line: int | None = None,
        record: int | None = None,
        column: str | None = None,
        column_index: int | None = None,
        col: int | None = None,
    ) -> None:
        self.message = message
        self.source = source
        self.line = line
        self.record = record
        self.column = column
        self.column_index = column_index
        what: list[str] = []
        if record is not None:
            what.append(f"record {record}")
        if column is not None:
            what.append(f"{'column' if column_index is not None else 'field'} {column!r}")
        text = f"{', '.join(what)}: {message}" if what else message
        file = source or ("<input>" if line is not None else "")
        col = (column_index or col) if line is not None else None
        super().__init__([LocatedProblem(file, line, col, text)])


__all__ = ["InputError"]
