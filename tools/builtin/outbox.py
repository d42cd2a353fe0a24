"""The outbox: where alerts go when no mail server or webhook is configured, so none is ever dropped.

Layout of ``outbox_dir``: one ``<UTC time>-<id>.eml`` (RFC 5322, attachments included) per e-mail, one
``<UTC time>-<id>.json`` (``{"time", "url", "payload"}``) per webhook payload, ``notifications.jsonl`` with one
JSON object per line for ``alerts.notify(channel="log")``, and ``undelivered-<call id>.eml``/``.json`` for an
alert whose mail server or webhook failed, whatever the failure, so the operator can forward it. File names sort
by time; files appear whole (written under a temporary name, then renamed), so a process forwarding the outbox
never reads half a message.

>>> import json, tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> path = write_file(folder, ".json", b'{"ok": true}')
>>> path.suffix, json.loads(path.read_text())
('.json', {'ok': True})
"""

from __future__ import annotations

import json
import os
import secrets
import threading
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

NOTIFICATIONS = "notifications.jsonl"
_append_lock = threading.Lock()


def now_iso() -> str:
    """The time now in UTC, ISO 8601 with microseconds (so strings sort as times)."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


def write_file(folder: Path, suffix: str, data: bytes) -> Path:
    """Write ``data`` to a new file in ``folder`` named by the time and a random id; returns its path."""
    folder.mkdir(parents=True, exist_ok=True)
    name = f"{datetime.now(UTC):%Y%m%dT%H%M%S%fZ}-{secrets.token_hex(4)}{suffix}"
    path = folder / name
    temporary = folder / f".{name}.tmp"
    temporary.write_bytes(data)
    os.replace(temporary, path)
    return path


def keep_undelivered(folder: Path, key: str | None, suffix: str, data: bytes) -> Path:
    """Keep an alert that could not be delivered: ``undelivered-<key><suffix>`` (a retry of the same call
    overwrites its own copy instead of adding one), or a new time-named file when there is no key."""
    if key is None:
        return write_file(folder, suffix, data)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"undelivered-{key}{suffix}"
    temporary = folder / f".{path.name}.tmp"
    temporary.write_bytes(data)
    os.replace(temporary, path)
    return path


def discard_undelivered(folder: Path, key: str | None, suffix: str) -> None:
    """Remove the copy an earlier attempt of this call kept, now that a later attempt delivered it."""
    if key is not None:
        (folder / f"undelivered-{key}{suffix}").unlink(missing_ok=True)


def append_line(folder: Path, record: dict[str, Any], name: str = NOTIFICATIONS) -> Path:
    """Append ``record`` as one JSON line to ``folder/name``; safe under concurrent callers of this process."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    line = json.dumps(record, ensure_ascii=False, default=str) + "\n"
    with _append_lock, path.open("a", encoding="utf-8") as file:
        file.write(line)
    return path


__all__ = ["NOTIFICATIONS", "append_line", "discard_undelivered", "keep_undelivered", "now_iso", "write_file"]
