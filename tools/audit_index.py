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

from typing import Generic, TypeVar

T = TypeVar("T")


class KeyIndex(Generic[T]):
    """Per key and tool, where the deciding record is (a byte offset, a record): only keys and locations are
    held, never outputs, so a file log's index stays small."""

    def __init__(self) -> None:
        self._entries: dict[str, dict[str, tuple[T, bool, int]]] = {}  # key -> tool -> (where, completed, order)

    def add(self, key: str, tool: str, where: T, completed: bool, order: int) -> None:
        """Note a record written after every one noted so far; ``completed``: it ran and ended ok."""
        tools = self._entries.setdefault(key, {})
        current = tools.get(tool)
        if current is None or not current[1]:
            tools[tool] = (where, completed, order)

    def best(self, key: str, tool: str | None = None) -> T | None:
        """The deciding record of ``key`` for ``tool`` (any tool when None: a completed one first)."""
        tools = self._entries.get(key)
        if not tools:
            return None
        if tool is not None:
            entry = tools.get(tool)
            return None if entry is None else entry[0]
        completed = [entry for entry in tools.values() if entry[1]]
        if completed:
            return min(completed, key=lambda entry: entry[2])[0]
        return max(tools.values(), key=lambda entry: entry[2])[0]

    def discard(self, key: str, tool: str, where: T) -> None:
        """Forget the record at ``where`` if it decides its key (a bounded log dropped it)."""
        tools = self._entries.get(key)
        if tools is not None and tool in tools and tools[tool][0] is where:
            del tools[tool]
            if not tools:
                del self._entries[key]

    def __len__(self) -> int:
        return len(self._entries)


__all__ = ["KeyIndex"]
