"""The append-only audit log of tool calls: time, caller, tool, redacted arguments, status, latency, attempts,
the stages passed and the call id; the caller's idempotency key, and a side-effect call's output, so a re-run
of the same action replays its result instead of acting twice. JSONL (one record a line) or SQLite (UPDATE and
DELETE refused)."""

from __future__ import annotations

import json
import os
import re
import sqlite3
import threading
import warnings
from collections import deque
from collections.abc import Mapping
from pathlib import Path
from typing import IO, Any, Protocol
from urllib.parse import quote

from pydantic import BaseModel, ConfigDict

from agentic_core.contracts.errors import AgenticUAVError

from .audit_index import KeyIndex
from .result import ToolStatus

REDACTED = "[redacted]"
_SECRET_WORDS = re.compile(
    r"(?:^|_)(?:pass(?:word|wd|phrase)?|secrets?|(?:\w+_)?tokens?|api_?key|apikey|auth(?:orization)?|credentials?|"
    r"private_key|cookies?|session_id|bearer|jwt|access_?key|secret_?key|signing_?key|pass_?code|pin_?code|otp)(?:$|_)"
)
_SECRET_SHAPES = re.compile(
    r"(?:Bearer\s+)?(?:eyJ[A-Za-z0-9_-]{5,}\.[A-Za-z0-9_-]{5,}\.[A-Za-z0-9_-]{5,}"  # a JWT
    r"|[0-9a-fA-F]{32,}"  # a hex key of 128 bits or more
    r"|(?=[A-Za-z0-9+/_-]*[0-9])(?=[A-Za-z0-9+/_-]*[A-Z])(?=[A-Za-z0-9+/_-]*[a-z])[A-Za-z0-9+/_-]{40,}={0,2})"
)


def looks_secret(value: str) -> bool:
    """Whether a whole string has the shape of a credential: a JWT, a long hex key, a long base64 key.

    >>> looks_secret("eyJhbGciOiJIUzI1NiJ9.eyJzdWIiOiJwaWxvdCJ9.c2lnbmF0dXJlLXNpZ25hdHVyZQ"), looks_secret("hover")
    (True, False)
    """
    return bool(_SECRET_SHAPES.fullmatch(value.strip()))


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
    idempotency_key: str | None = None  # the caller's name for the action, when it gave one
    side_effects: bool = False  # the tool acts outside the run
    output: Any = None  # a side-effect call's output that ended ok (redacted), for replays; else None
    output_kept: bool = False  # whether ``output`` holds it (it may be over the size kept, or not recorded at all)
    replay_of: str | None = None  # the call whose recorded result this one returned without running the tool


def completes(record: AuditRecord) -> bool:
    """Whether a record is of a call that ran (or was served) and ended ok: the result a re-run replays."""
    return record.status == "ok" and record.replay_of is None


class AuditLogWarning(AgenticUAVError, UserWarning):
    """A line of a JSONL audit log is not a record (a write cut short by a crash leaves one): it is skipped."""


def redact(value: Any, sensitive: frozenset[str] = frozenset()) -> Any:
    """``value`` with the values of secret-looking keys (and of ``sensitive`` ones), and strings shaped like keys
    or tokens, replaced, at any depth."""
    if isinstance(value, Mapping):
        return {k: REDACTED if (k in sensitive or is_secret_key(k)) else redact(v, sensitive) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [redact(v, sensitive) for v in value]
    if isinstance(value, str) and looks_secret(value):
        return REDACTED
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
    """Where the executor records calls. ``write`` is durable on return for a record with ``side_effects``;
    ``find`` answers for keys written by earlier processes too (for the file logs)."""

    def write(self, record: AuditRecord) -> None: ...
    def find(self, idempotency_key: str, tool: str | None = None) -> AuditRecord | None:
        """The record that decides a key (of ``tool``, or any): the first call that ran and ended ok, else the
        latest; None when the key was never recorded."""
        ...

    def close(self) -> None: ...


class MemoryAuditLog:
    """Keeps the latest ``max_records`` records in memory (the default when no file is given; tests read
    ``records``). Older ones are counted in ``dropped``, never silently, and their keys are forgotten: for a
    complete log, and keys that outlive the process, use a file."""

    def __init__(self, max_records: int = 10_000) -> None:
        self._records: deque[AuditRecord] = deque(maxlen=max_records)
        self.max_records = max_records
        self.dropped = 0
        self._keys: KeyIndex[AuditRecord] = KeyIndex()
        self._written = 0
        self._lock = threading.Lock()

    @property
    def records(self) -> list[AuditRecord]:
        with self._lock:
            return list(self._records)

    def write(self, record: AuditRecord) -> None:
        with self._lock:
            if len(self._records) == self.max_records:
                self.dropped += 1
                oldest = self._records[0]
                if oldest.idempotency_key is not None:
                    self._keys.discard(oldest.idempotency_key, oldest.tool, oldest)
            self._records.append(record)
            self._written += 1
            if record.idempotency_key is not None:
                self._keys.add(record.idempotency_key, record.tool, record, completes(record), self._written)

    def find(self, idempotency_key: str, tool: str | None = None) -> AuditRecord | None:
        with self._lock:
            return self._keys.best(idempotency_key, tool)

    def close(self) -> None:
        pass


def _line(record: AuditRecord) -> bytes:
    try:
        return (record.model_dump_json() + "\n").encode()
    except ValueError:  # values with no JSON form: kept as their repr, as the SQLite log does
        return (json.dumps(record.model_dump(), default=repr) + "\n").encode()


class JsonlAuditLog:
    """Appends one JSON object a line, each in one unbuffered write, so a crash loses at most the call in
    progress; a side-effect call's line (not a replay's) is fsync'd before ``write`` returns. ``find`` indexes the
    file on its first look-up, then the lines appended since (by any process): only keys, tool names and byte
    offsets are held in memory, and the record found is read back from the file. A line that is not a record (a
    write cut short by a crash) is skipped with an :class:`AuditLogWarning`."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        self._lock = threading.Lock()
        self._closed = False
        self._reader: IO[bytes] | None = None
        self._keys: KeyIndex[int] = KeyIndex()
        self._indexed_to = 0  # bytes of the file indexed so far
        self._lines = 0  # lines of the file indexed so far
        self._end_cut_line()

    def _end_cut_line(self) -> None:
        """End a last line a killed writer left without its newline, so the next record starts a line of its own."""
        with self.path.open("rb") as file:
            if file.seek(0, os.SEEK_END) == 0:
                return
            file.seek(-1, os.SEEK_END)
            if file.read(1) == b"\n":
                return
        os.write(self._fd, b"\n")
        warnings.warn(
            f"{self.path}: the last line was cut short (a write interrupted by a crash?); it is skipped",
            AuditLogWarning,
            stacklevel=3,
        )

    def write(self, record: AuditRecord) -> None:
        data = _line(record)
        with self._lock:
            if self._closed:
                raise ValueError(f"the audit log {self.path} is closed")
            view = memoryview(data)
            while view:
                view = view[os.write(self._fd, view) :]
            if record.side_effects and record.replay_of is None:  # a replay did nothing to lose
                os.fsync(self._fd)

    def find(self, idempotency_key: str, tool: str | None = None) -> AuditRecord | None:
        with self._lock:
            if self._closed:
                raise ValueError(f"the audit log {self.path} is closed")
            reader = self._catch_up()
            offset = self._keys.best(idempotency_key, tool)
            if offset is None:
                return None
            reader.seek(offset)
            line = reader.readline()
        return AuditRecord.model_validate_json(line)

    def _catch_up(self) -> IO[bytes]:
        """Index the complete lines appended since the last look-up; the reader, for reading a record back."""
        if self._reader is None:
            self._reader = self.path.open("rb")
        reader = self._reader
        if os.fstat(reader.fileno()).st_size < self._indexed_to:  # cut down by someone: index it afresh
            self._keys, self._indexed_to, self._lines = KeyIndex(), 0, 0
        reader.seek(self._indexed_to)
        offset = self._indexed_to
        for line in reader:
            if not line.endswith(b"\n"):
                break  # still being written (or cut short and not yet ended): looked at again next time
            self._lines += 1
            self._index_line(line, offset)
            offset += len(line)
        self._indexed_to = offset
        return reader

    def _index_line(self, line: bytes, offset: int) -> None:
        if not line.strip():
            return
        try:
            data = json.loads(line)
            key, tool = data.get("idempotency_key"), data["tool"]
            if key is not None and not (isinstance(key, str) and isinstance(tool, str)):
                raise ValueError("a key or tool that is not a string")
        except (ValueError, KeyError, AttributeError) as exc:
            warnings.warn(
                f"{self.path}:{self._lines}: skipped a line that is not an audit record ({type(exc).__name__})",
                AuditLogWarning,
                stacklevel=4,
            )
            return
        if key is not None:
            done = data.get("status") == "ok" and data.get("replay_of") is None
            self._keys.add(key, tool, offset, done, offset)

    def close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            os.close(self._fd)
            if self._reader is not None:
                self._reader.close()


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
_ADDED = {  # columns newer than the first schema: added to an older file when it is opened
    "idempotency_key": "TEXT",
    "side_effects": "INTEGER NOT NULL DEFAULT 0",
    "output": "TEXT",
    "output_kept": "INTEGER NOT NULL DEFAULT 0",
    "replay_of": "TEXT",
}
_KEY_INDEX = (
    "CREATE INDEX IF NOT EXISTS tool_calls_key ON tool_calls (idempotency_key, tool, seq) "
    "WHERE idempotency_key IS NOT NULL"
)
_FIRST = ("time", "call_id", "caller", "tool", "args", "status", "latency_s", "attempts", "cached", "error", "stages")
_COLUMNS = (*_FIRST, *_ADDED)
_FLAGS = ("cached", "side_effects", "output_kept")


def _record(row: Mapping[str, Any]) -> AuditRecord:
    data = dict(row)
    data["args"] = json.loads(data["args"])
    data["stages"] = json.loads(data["stages"])
    data["output"] = json.loads(data["output"]) if data.get("output") is not None else None
    for flag in _FLAGS:
        if flag in data:
            data[flag] = bool(data[flag])
    return AuditRecord.model_validate(data)


class SqliteAuditLog:
    """Appends rows to ``tool_calls``; triggers refuse UPDATE and DELETE. WAL mode: a committed row survives the
    process being killed; a side-effect call's row is also synced to disk (``synchronous=FULL``) before ``write``
    returns. ``find`` uses an index on the key, so nothing is held in memory."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_SCHEMA)
        present = {row[1] for row in self._db.execute("PRAGMA table_info(tool_calls)")}
        for column, kind in _ADDED.items():
            if column not in present:
                self._db.execute(f"ALTER TABLE tool_calls ADD COLUMN {column} {kind}")
        self._db.execute(_KEY_INDEX)
        self._lock = threading.Lock()

    def write(self, record: AuditRecord) -> None:
        row = record.model_dump()
        row["args"] = json.dumps(row["args"], default=repr)
        row["stages"] = json.dumps(row["stages"])
        row["output"] = json.dumps(row["output"], default=repr) if record.output_kept else None
        insert = f"INSERT INTO tool_calls ({', '.join(_COLUMNS)}) VALUES ({', '.join('?' * len(_COLUMNS))})"
        with self._lock:
            if not record.side_effects or record.replay_of is not None:
                self._db.execute(insert, [row[c] for c in _COLUMNS])
                return
            self._db.execute("PRAGMA synchronous=FULL")
            try:
                self._db.execute(insert, [row[c] for c in _COLUMNS])
            finally:
                self._db.execute("PRAGMA synchronous=NORMAL")

    def find(self, idempotency_key: str, tool: str | None = None) -> AuditRecord | None:
        where = "idempotency_key = ?" + (" AND tool = ?" if tool is not None else "")
        values = [idempotency_key] if tool is None else [idempotency_key, tool]
        select = f"SELECT {', '.join(_COLUMNS)} FROM tool_calls WHERE {where}"
        with self._lock:
            row = self._db.execute(
                f"{select} AND status = 'ok' AND replay_of IS NULL ORDER BY seq LIMIT 1", values
            ).fetchone()
            if row is None:
                row = self._db.execute(f"{select} ORDER BY seq DESC LIMIT 1", values).fetchone()
        return None if row is None else _record(dict(zip(_COLUMNS, row, strict=True)))

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
    """Every record of a JSONL or SQLite audit log, oldest first; a JSONL line that is not a record (a write cut
    short by a crash) is skipped with an :class:`AuditLogWarning` naming its line."""
    target = Path(path)
    if target.suffix.lower() == ".jsonl":
        records = []
        with target.open("rb") as lines:
            for number, line in enumerate(lines, 1):
                if not line.strip():
                    continue
                try:
                    records.append(AuditRecord.model_validate_json(line))
                except ValueError as exc:
                    reason = f"{type(exc).__name__}, {len(line)} bytes"
                    warnings.warn(
                        f"{target}:{number}: skipped a line that is not an audit record ({reason})",
                        AuditLogWarning,
                        stacklevel=2,
                    )
        return records
    db = sqlite3.connect(target)
    try:
        present = {row[1] for row in db.execute("PRAGMA table_info(tool_calls)")}
        columns = [c for c in _COLUMNS if c in present]  # a file written before the newer columns has fewer
        rows = db.execute(f"SELECT {', '.join(columns)} FROM tool_calls ORDER BY seq").fetchall()
    finally:
        db.close()
    return [_record(dict(zip(columns, row, strict=True))) for row in rows]
