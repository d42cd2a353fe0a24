"""Checkpoints in a SQLite database (stdlib ``sqlite3``): a run killed mid-mission resumes in a new process.

The database runs in WAL mode with ``synchronous=NORMAL``: every committed checkpoint survives the process being
killed; a power cut may lose the last few (use ``durable=True`` for a full fsync per checkpoint).
"""

from __future__ import annotations

import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .base import BaseCheckpointSaver, CheckpointRow, Serializer

_SCHEMA = """
CREATE TABLE IF NOT EXISTS agentic_checkpoints (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    thread_id TEXT NOT NULL,
    ns TEXT NOT NULL,
    checkpoint_id TEXT NOT NULL,
    parent_id TEXT,
    step INTEGER NOT NULL,
    source TEXT NOT NULL,
    created_at REAL NOT NULL,
    body BLOB NOT NULL,
    UNIQUE (thread_id, ns, checkpoint_id)
);
CREATE INDEX IF NOT EXISTS agentic_checkpoints_thread ON agentic_checkpoints (thread_id, ns, seq);
CREATE TABLE IF NOT EXISTS agentic_writes (
    thread_id TEXT NOT NULL,
    ns TEXT NOT NULL,
    checkpoint_id TEXT NOT NULL,
    task_id TEXT NOT NULL,
    body BLOB NOT NULL,
    PRIMARY KEY (thread_id, ns, checkpoint_id, task_id)
);
"""


class SqliteSaver(BaseCheckpointSaver):
    """Checkpoints in SQLite. Pass a path, ``":memory:"`` or an open ``sqlite3.Connection``.

    >>> from agentic_core.graph import SqliteSaver
    >>> saver = SqliteSaver(":memory:")
    """

    def __init__(
        self,
        conn: sqlite3.Connection | str | Path,
        *,
        serde: Serializer | None = None,
        durable: bool = False,
    ) -> None:
        super().__init__(serde)
        if isinstance(conn, sqlite3.Connection):
            self.conn = conn
            self._owns = False
        else:
            if str(conn) != ":memory:":
                Path(conn).parent.mkdir(parents=True, exist_ok=True)
            self.conn = sqlite3.connect(str(conn), check_same_thread=False, isolation_level=None)
            self._owns = True
        self.conn.execute("PRAGMA journal_mode=WAL")
        self.conn.execute(f"PRAGMA synchronous={'FULL' if durable else 'NORMAL'}")
        self.conn.executescript(_SCHEMA)
        self.conn.commit()

    @classmethod
    @contextmanager
    def from_conn_string(cls, conn_string: str) -> Iterator[SqliteSaver]:
        """``with SqliteSaver.from_conn_string("runs/checkpoints.sqlite") as saver: ...`` (LangGraph's shape)."""
        saver = cls(conn_string)
        try:
            yield saver
        finally:
            saver.close()

    def close(self) -> None:
        if self._owns:
            self.conn.close()

    def _write(self, sql: str, params: tuple[object, ...]) -> None:
        self.conn.execute(sql, params)
        if self.conn.in_transaction:
            self.conn.commit()

    def _put_row(self, thread_id: str, ns: str, row: CheckpointRow) -> None:
        self._write(
            "INSERT INTO agentic_checkpoints (thread_id, ns, checkpoint_id, parent_id, step, source, created_at, body)"
            " VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
            (thread_id, ns, row.id, row.parent_id, row.step, row.source, row.created_at, row.body),
        )

    def _rows(self, thread_id: str, ns: str) -> list[CheckpointRow]:
        cur = self.conn.execute(
            "SELECT checkpoint_id, parent_id, step, source, created_at, body FROM agentic_checkpoints"
            " WHERE thread_id = ? AND ns = ? ORDER BY seq",
            (thread_id, ns),
        )
        return [CheckpointRow(*r) for r in cur.fetchall()]

    def _put_outcome(self, thread_id: str, ns: str, checkpoint_id: str, task_id: str, body: bytes) -> None:
        self._write(
            "INSERT OR REPLACE INTO agentic_writes (thread_id, ns, checkpoint_id, task_id, body)"
            " VALUES (?, ?, ?, ?, ?)",
            (thread_id, ns, checkpoint_id, task_id, body),
        )

    def _outcomes(self, thread_id: str, ns: str, checkpoint_id: str) -> dict[str, bytes]:
        cur = self.conn.execute(
            "SELECT task_id, body FROM agentic_writes WHERE thread_id = ? AND ns = ? AND checkpoint_id = ?",
            (thread_id, ns, checkpoint_id),
        )
        return {tid: body for tid, body in cur.fetchall()}

    def delete_thread(self, thread_id: str) -> None:
        with self._lock:
            self.conn.execute("DELETE FROM agentic_checkpoints WHERE thread_id = ?", (thread_id,))
            self.conn.execute("DELETE FROM agentic_writes WHERE thread_id = ?", (thread_id,))
            if self.conn.in_transaction:
                self.conn.commit()

    def storage_bytes(self) -> int:
        """Bytes of serialized checkpoint data held, for measuring checkpoint growth."""
        row = self.conn.execute("SELECT COALESCE(SUM(LENGTH(body)), 0) FROM agentic_checkpoints").fetchone()
        wrow = self.conn.execute("SELECT COALESCE(SUM(LENGTH(body)), 0) FROM agentic_writes").fetchone()
        return int(row[0]) + int(wrow[0])
