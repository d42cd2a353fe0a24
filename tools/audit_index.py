"""Which audit record decides an idempotency key: the first call with that key that ran and ended ok (its result
is what a re-run replays), else the latest one (it says why the action must run again).

>>> index: KeyIndex[str] = KeyIndex()
>>> index.add("run-1:alert:0", "alerts.notify", "line 1", False, 1)  # timed out
>>> index.add("run-1:alert:0", "alerts.notify", "line 2", True, 2)  # ran again, ok
>>> index.add("run-1:alert:0", "alerts.notify", "line 3", False, 3)  # a later failure changes nothing
>>> index.best("run-1:alert:0", "alerts.notify"), index.best("run-1:alert:0", "incidents.log")
('line 2', None)
"""

from __future__ import annotations

import sys
from typing import Generic, TypeVar

T = TypeVar("T")


class KeyIndex(Generic[T]):
    """Per key and tool, where the deciding record is (a byte offset, a record): only keys and locations are
    held, never outputs, so a file log's index stays small (a key of one tool, the usual case, is one tuple)."""

    def __init__(self) -> None:
        # key -> (tool, where, completed, order), or a list of them when several tools used the key
        self._entries: dict[str, tuple[str, T, bool, int] | list[tuple[str, T, bool, int]]] = {}

    def add(self, key: str, tool: str, where: T, completed: bool, order: int) -> None:
        """Note a record written after every one noted so far; ``completed``: it ran and ended ok."""
        entry = (sys.intern(tool), where, completed, order)
        current = self._entries.get(key)
        if current is None:
            self._entries[key] = entry
            return
        entries = current if isinstance(current, list) else [current]
        for index, (other, _, done, _) in enumerate(entries):
            if other == tool:
                if not done:
                    entries[index] = entry
                break
        else:
            entries.append(entry)
        self._entries[key] = entries[0] if len(entries) == 1 else entries

    def _of(self, key: str) -> list[tuple[str, T, bool, int]]:
        current = self._entries.get(key)
        if current is None:
            return []
        return current if isinstance(current, list) else [current]

    def best(self, key: str, tool: str | None = None) -> T | None:
        """The deciding record of ``key`` for ``tool`` (any tool when None: a completed one first)."""
        entries = self._of(key)
        if tool is not None:
            return next((entry[1] for entry in entries if entry[0] == tool), None)
        if not entries:
            return None
        completed = [entry for entry in entries if entry[2]]
        if completed:
            return min(completed, key=lambda entry: entry[3])[1]
        return max(entries, key=lambda entry: entry[3])[1]

    def discard(self, key: str, tool: str, where: T) -> None:
        """Forget the record at ``where`` if it decides its key (a bounded log dropped it)."""
        kept = [entry for entry in self._of(key) if not (entry[0] == tool and entry[1] is where)]
        if not kept:
            self._entries.pop(key, None)
        else:
            self._entries[key] = kept[0] if len(kept) == 1 else kept

    def __len__(self) -> int:
        return len(self._entries)


__all__ = ["KeyIndex"]
