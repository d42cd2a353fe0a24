"""The one located problem: what is wrong with an input file and where, printed ``file:line:col: message``.

Mission files, scene files, tool definition files and statistics input all report through it, so an editor or a
terminal can jump to every problem the same way. Line and column are 1-based; a part that is not known is left
out cleanly (``file:line: message``, ``file: message``). :class:`ProblemsError` carries every problem found, in
file order, and is bad input (exit 2).

>>> str(LocatedProblem("mission.yaml", 14, 15, "alt_m must be positive"))
'mission.yaml:14:15: alt_m must be positive'
>>> str(LocatedProblem("results.csv", 3, None, "non-numeric value 'fast'"))
"results.csv:3: non-numeric value 'fast'"
>>> str(LocatedProblem("f.yaml", None, None, "the file is empty"))
'f.yaml: the file is empty'

>>> print(ProblemsError([LocatedProblem("a.yaml", 9, 1, "second"), LocatedProblem("a.yaml", 2, 5, "first")]))
a.yaml:2:5: first
a.yaml:9:1: second
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from .errors import InputError


@dataclass(frozen=True)
class LocatedProblem:
    """One thing wrong with an input: its file, 1-based line and column when known, and what is wrong."""

    file: str
    line: int | None
    col: int | None
    message: str

    def __post_init__(self) -> None:
        for name, value in (("line", self.line), ("col", self.col)):
            if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
                raise ValueError(f"a problem's {name} is 1-based, not {value!r}")
        if self.col is not None and self.line is None:
            raise ValueError("a problem with a column needs its line")

    @property
    def sort_key(self) -> tuple[str, int, int, str]:
        """File order: by file, then line and column (an unplaced problem first), then message."""
        return self.file, self.line or 0, self.col or 0, self.message

    def __lt__(self, other: LocatedProblem) -> bool:
        return self.sort_key < other.sort_key

    def __str__(self) -> str:
        where = ":".join(str(part) for part in (self.file, self.line, self.col) if part not in (None, ""))
        return f"{where}: {self.message}" if where else self.message


class ProblemsError(InputError):
    """Bad input with every problem found in it (``problems``, in file order); its message is one per line."""

    def __init__(self, problems: Sequence[LocatedProblem]) -> None:
        if not problems:
            raise ValueError("a ProblemsError needs at least one problem")
        self.problems = sorted(problems)
        super().__init__("\n".join(str(p) for p in self.problems))


__all__ = ["LocatedProblem", "ProblemsError"]
