"""The store's tables in SQLite, and what one row of them becomes.

Items are rows keyed by ``(ns, key)``; their vectors (one per indexed text) are float32 BLOBs; their words are an
FTS5 table whose rowid is the item's id; every write, invalidation and deletion is appended to ``store_history``.
"""

from __future__ import annotations

import json
import sqlite3
from datetime import UTC, datetime
from typing import Any

from agentic_core.contracts.errors import InputError

from .items import Invalidation, Item, SearchItem
from .namespaces import decode

SCHEMA_VERSION = "1"

TABLES = """
CREATE TABLE IF NOT EXISTS store_meta (name TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS store_items (
    id INTEGER PRIMARY KEY,
    ns TEXT NOT NULL,
    key TEXT NOT NULL,
    value TEXT NOT NULL,
    created_at TEXT NOT NULL,
    updated_at TEXT NOT NULL,
    ttl_minutes REAL,
    expires_at REAL,
    invalid_reason TEXT,
    invalid_at TEXT,
    invalid_by TEXT,
    UNIQUE (ns, key)
);
CREATE INDEX IF NOT EXISTS store_items_ns ON store_items (ns);
CREATE TABLE IF NOT EXISTS store_vectors (item_id INTEGER NOT NULL, path TEXT NOT NULL, vec BLOB NOT NULL);
CREATE INDEX IF NOT EXISTS store_vectors_item ON store_vectors (item_id);
CREATE VIRTUAL TABLE IF NOT EXISTS store_words USING fts5 (body, tokenize = 'unicode61 remove_diacritics 2');
CREATE VIRTUAL TABLE IF NOT EXISTS store_words_vocab USING fts5vocab (store_words, 'row');
CREATE TABLE IF NOT EXISTS store_history (
    id INTEGER PRIMARY KEY,
    ns TEXT NOT NULL,
    key TEXT NOT NULL,
    event TEXT NOT NULL,
    value TEXT,
    at TEXT NOT NULL,
    reason TEXT,
    by TEXT
);
CREATE INDEX IF NOT EXISTS store_history_item ON store_history (ns, key);
"""

COLUMNS = "id, ns, key, value, created_at, updated_at, invalid_reason, invalid_at, invalid_by"


def now() -> datetime:
    return datetime.now(UTC)


def create(conn: sqlite3.Connection, index_name: str | None, dims: int | None) -> None:
    """Create the tables; refuse a file indexed with another embedder or width than this store's."""
    conn.executescript(TABLES)
    meta = dict(conn.execute("SELECT name, value FROM store_meta").fetchall())
    if meta.get("schema", SCHEMA_VERSION) != SCHEMA_VERSION:
        raise InputError(f"memory store: schema {meta['schema']!r}, this version reads {SCHEMA_VERSION!r}")
    wanted = {"schema": SCHEMA_VERSION}
    if index_name is not None:
        wanted |= {"embed": index_name, "dims": str(dims or "")}
        for field in ("embed", "dims"):
            if field in meta and meta[field] and wanted[field] and meta[field] != wanted[field]:
                raise InputError(
                    f"memory store: its vectors were made with {field} {meta[field]!r}, this store is configured "
                    f"with {wanted[field]!r}; use the same index config, or a new file"
                )
    for name, value in wanted.items():
        if value:
            conn.execute("INSERT OR IGNORE INTO store_meta (name, value) VALUES (?, ?)", (name, value))


def to_json(value: object, where: str) -> str:
    """``value`` as JSON text, or InputError naming the item when it is not JSON-ready."""
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise InputError(f"{where}: a value is a mapping with string keys, got {type(value).__name__}")
    try:
        return json.dumps(value, ensure_ascii=False, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where}: the value is not JSON ({exc})") from None


def item(row: tuple[Any, ...], score: float | None = None, *, search: bool = False) -> Item:
    """An :class:`Item` (or :class:`SearchItem`) from a row of :data:`COLUMNS`."""
    _, ns, key, value, created, updated, reason, at, by = row
    fields: dict[str, Any] = {
        "value": json.loads(value),
        "key": key,
        "namespace": decode(ns),
        "created_at": datetime.fromisoformat(created),
        "updated_at": datetime.fromisoformat(updated),
        "invalidated": None if reason is None else Invalidation(reason, datetime.fromisoformat(at), by or ""),
    }
    return SearchItem(score=score, **fields) if search else Item(**fields)
