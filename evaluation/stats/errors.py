"""The one error type for a user's bad input; its message names the file, the line (or record), the column."""

from __future__ import annotations

from agentic_core.contracts.errors import InputError as _InputError


class InputError(_InputError):
    """Bad input: a missing or unreadable file, an unknown column, a non-numeric value, too few groups.

    ``str(error)`` reads ``results.csv, line 12, column 3 'processing_time_s': non-numeric value 'fast'``.
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
    ) -> None:
        super().__init__(message)
        self.message = message
        self.source = source
        self.line = line
        self.record = record
        self.column = column
        self.column_index = column_index

    def __str__(self) -> str:
        where: list[str] = []
        if self.source:
            where.append(self.source)
        if self.line is not None:
            where.append(f"line {self.line}")
        if self.record is not None:
            where.append(f"record {self.record}")
        if self.column is not None:
            if self.column_index is not None:
                where.append(f"column {self.column_index} {self.column!r}")
            else:
                where.append(f"field {self.column!r}")
        return f"{', '.join(where)}: {self.message}" if where else self.message


__all__ = ["InputError"]
