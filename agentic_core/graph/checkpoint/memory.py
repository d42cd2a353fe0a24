"""Checkpoints kept in the process's memory: for tests, notebooks and runs that need not survive a crash."""

from __future__ import annotations

from collections import defaultdict

from .base import BaseCheckpointSaver, CheckpointRow, Serializer


class InMemorySaver(BaseCheckpointSaver):
    """Keeps checkpoints in a dict, serialized so later mutation of state objects cannot rewrite history.

    >>> from agentic_core.graph import InMemorySaver
    >>> saver = InMemorySaver()
    """

    def __init__(self, serde: Serializer | None = None) -> None:
        super().__init__(serde)
        self._store: dict[tuple[str, str], list[CheckpointRow]] = defaultdict(list)
        self._writes: dict[tuple[str, str, str], dict[str, bytes]] = defaultdict(dict)

    def _put_row(self, thread_id: str, ns: str, row: CheckpointRow) -> None:
        self._store[(thread_id, ns)].append(row)

    def _rows(self, thread_id: str, ns: str) -> list[CheckpointRow]:
        return list(self._store.get((thread_id, ns), ()))

    def _put_outcome(self, thread_id: str, ns: str, checkpoint_id: str, task_id: str, body: bytes) -> None:
        self._writes[(thread_id, ns, checkpoint_id)][task_id] = body

    def _outcomes(self, thread_id: str, ns: str, checkpoint_id: str) -> dict[str, bytes]:
        return dict(self._writes.get((thread_id, ns, checkpoint_id), {}))

    def delete_thread(self, thread_id: str) -> None:
        with self._lock:
            for key in [k for k in self._store if k[0] == thread_id]:
                del self._store[key]
            for wkey in [k for k in self._writes if k[0] == thread_id]:
                del self._writes[wkey]

    def storage_bytes(self) -> int:
        """Bytes of serialized checkpoint data held, for measuring checkpoint growth."""
        rows = sum(len(r.body) for rs in self._store.values() for r in rs)
        return rows + sum(len(b) for ws in self._writes.values() for b in ws.values())


MemorySaver = InMemorySaver
"""LangGraph's older name for :class:`InMemorySaver` (``langgraph.checkpoint.memory.MemorySaver``).

>>> MemorySaver is InMemorySaver
True
"""
