"""The append-only audit log of tool calls: time, caller, tool, redacted arguments, status, latency, attempts,
the stages passed and the call id. JSONL (one record a line) or SQLite (UPDATE and DELETE refused)."""

from __future__ import annotations

import json
import re
import sqlite3
import threading
from collections import deque
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol
from urllib.parse import quote

from pydantic import BaseModel, ConfigDict

from .result import ToolStatus

REDACTED = "[redacted]"
_SECRET_WORDS = re.compile(
    r"(?:^|_)(?:pass(?:word|wd|phrase)?|secrets?|(?:\w+_)?tokens?|api_?key|apikey|auth(?:orization)?|credentials?|"
    r"private_key|cookies?|session_id|bearer)(?:$|_)"
)


def is_secret_key(key: object) -> bool:
    """Whether an argument name says it holds a secret: ``password``, ``smtp_password``, ``apiKey``,
    ``access_token``, ``Authorization``; not ``compass_heading``, ``passenger_count`` or ``author``."""
    words = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", str(key)).replace("-", "_").replace(".", "_").lower()
    return bool(_SECRET_WORDS.search(words))


class AuditRecord(BaseModel):
    """One tool call as the audit log keeps it."""

    model_config = ConfigDict(frozen=True)

    time: str  # ISO 8601, UTC
    call_id: str
    caller: str
    tool: str
    args: Any
    status: ToolStatus
    latency_s: float
    attempts: int
    cached: bool
    error: str | None
    stages: list[str]  # "name:outcome", in order


def redact(value: Any, sensitive: frozenset[str] = frozenset()) -> Any:
    """``value`` with the values of secret-looking keys (and of ``sensitive`` ones) replaced, at any depth."""
    if isinstance(value, Mapping):
        return {k: REDACTED if (k in sensitive or is_secret_key(k)) else redact(v, sensitive) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [redact(v, sensitive) for v in value]
    return value


def secret_values(value: Any, sensitive: frozenset[str] = frozenset()) -> list[str]:
    """The text of every value :func:`redact` hides (4 characters or more), in the forms messages quote it in,
    longest first, to scrub from messages."""
    found: list[str] = []

    def walk(item: Any, hidden: bool) -> None:
        if isinstance(item, Mapping):
            for key, inner in item.items():
                walk(inner, hidden or key in sensitive or is_secret_key(key))
        elif isinstance(item, list | tuple):
            for inner in item:
                walk(inner, hidden)
        elif hidden and not isinstance(item, bool) and len(str(item)) >= 4:
            found.append(str(item))

    walk(value, False)
    forms = {form for text in found for form in (text, repr(text)[1:-1], json.dumps(text)[1:-1], quote(text, safe=""))}
    return sorted(forms, key=len, reverse=True)  # as written, and as repr, JSON and URLs quote it in messages


class AuditLog(Protocol):
    def write(self, record: AuditRecord) -> None: ...
    def close(self) -> None: ...


class MemoryAuditLog:
    """Keeps the latest ``max_records`` records in memory (the default when no file is given; tests read
    ``records``). Older ones are counted in ``dropped``, never silently: for a complete log, use a file."""

    def __init__(self, max_records: int = 10_000) -> None:
        self._records: deque[AuditRecord] = deque(maxlen=max_records)
        self.max_records = max_records
        self.dropped = 0
        self._lock = threading.Lock()

    @property
    def records(self) -> list[AuditRecord]:
        with self._lock:
            return list(self._records)

    def write(self, record: AuditRecord) -> None:
        with self._lock:
            if len(self._records) == self.max_records:
                self.dropped += 1
            self._records.append(record)

    def close(self) -> None:
        pass


class JsonlAuditLog:
    """Appends one JSON object a line, flushed at once so a crash loses at most the call in progress."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = self.path.open("a", encoding="utf-8")
        self._lock = threading.Lock()

    def write(self, record: AuditRecord) -> None:
        try:
            line = record.model_dump_json() + "\n"
        except ValueError:  # arguments with no JSON form: kept as their repr, as the SQLite log does
            line = json.dumps(record.model_dump(), default=repr) + "\n"
        with self._lock:
            self._file.write(line)
            self._file.flush()

    def close(self) -> None:
        with self._lock:
            self._file.close()


_SCHEMA = """
CREATE TABLE IF NOT EXISTS tool_calls (
    seq INTEGER PRIMARY KEY AUTOINCREMENT, time TEXT NOT NULL, call_id TEXT NOT NULL, caller TEXT NOT NULL,
    tool TEXT NOT NULL, args TEXT NOT NULL, status TEXT NOT NULL, latency_s REAL NOT NULL, attempts INTEGER NOT NULL,
    cached INTEGER NOT NULL, error TEXT, stages TEXT NOT NULL);
CREATE INDEX IF NOT EXISTS tool_calls_tool ON tool_calls (tool, time);
CREATE TRIGGER IF NOT EXISTS tool_calls_no_update BEFORE UPDATE ON tool_calls
    BEGIN SELECT RAISE(ABORT, 'the audit log is append-only'); END;
CREATE TRIGGER IF NOT EXISTS tool_calls_no_delete BEFORE DELETE ON tool_calls
    BEGIN SELECT RAISE(ABORT, 'the audit log is append-only'); END;
"""
_COLUMNS = ("time", "call_id", "caller", "tool", "args", "status", "latency_s", "attempts", "cached", "error", "stages")


class SqliteAuditLog:
    """Appends rows to ``tool_calls``; triggers refuse UPDATE and DELETE."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_SCHEMA)
        self._lock = threading.Lock()

    def write(self, record: AuditRecord) -> None:
        row = record.model_dump()
        row["args"] = json.dumps(row["args"], default=repr)
        row["stages"] = json.dumps(row["stages"])
        with self._lock:
            self._db.execute(
                f"INSERT INTO tool_calls ({', '.join(_COLUMNS)}) VALUES ({', '.join('?' * len(_COLUMNS))})",
                [row[c] for c in _COLUMNS],
            )

    def close(self) -> None:
        with self._lock:
            self._db.close()


def open_audit_log(path: str | Path) -> JsonlAuditLog | SqliteAuditLog:
    """A JSONL log for ``*.jsonl``, SQLite for ``*.db``/``*.sqlite``/``*.sqlite3``."""
    suffix = Path(path).suffix.lower()
    if suffix == ".jsonl":
        return JsonlAuditLog(path)
    if suffix in (".db", ".sqlite", ".sqlite3"):
        return SqliteAuditLog(path)
    raise ValueError(f"audit log {str(path)!r}: use a .jsonl file or a .db/.sqlite file")


def read_audit_log(path: str | Path) -> list[AuditRecord]:
    """Every record of a JSONL or SQLite audit log, oldest first."""
    target = Path(path)
    if target.suffix.lower() == ".jsonl":
        with target.open(encoding="utf-8") as lines:
            return [AuditRecord.model_validate_json(line) for line in lines if line.strip()]
    db = sqlite3.connect(target)
    try:
        rows = db.execute(f"SELECT {', '.join(_COLUMNS)} FROM tool_calls ORDER BY seq").fetchall()
    finally:
        db.close()
    records = []
    for row in rows:
        data = dict(zip(_COLUMNS, row, strict=True))
        data["args"] = json.loads(data["args"])
        data["stages"] = json.loads(data["stages"])
        data["cached"] = bool(data["cached"])
        records.append(AuditRecord.model_validate(data))
    return records
