"""Knowledge documents into the fleet's memory (``agentic-uav memory ingest FILES``): Markdown with a front matter
naming its ``source``, ``version`` and ``valid_until``, cut into chunks at headings and paragraphs.

A chunk is keyed ``<document>@<version>#<n>`` under ``("knowledge", <document>)``; ingesting a new version
invalidates the chunks of the older ones ("superseded by version X"), which stay readable. Chunks past their
``valid_until`` are left out of :func:`search_knowledge`.

>>> chunks = chunk("# Heat\\n\\nCool first.\\n\\n## Transport\\n\\nThen move.", max_chars=40)
>>> [c[0] for c in chunks], chunks[1][1]
(['Heat', 'Heat / Transport'], 'Heat / Transport\\n\\nThen move.')
"""

from __future__ import annotations

import datetime as dt
import re
from pathlib import Path
from typing import Any

import yaml

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.input_files import check_input_file

from .items import SearchItem
from .store import SqliteStore

ROOT = "knowledge"
MAX_CHARS = 700
REQUIRED = ("source", "version", "valid_until")
_HEADING = re.compile(r"^(#{1,6})\s+(.*\S)\s*$")
_NAME = re.compile(r"[^A-Za-z0-9_-]+")


def front_matter(text: str, where: str) -> tuple[dict[str, Any], str, int]:
    """The front matter's fields, the body, and the body's first line number; InputError naming file:line."""
    lines = text.splitlines()
    if not lines or lines[0].strip() != "---":
        raise InputError(f"{where}:1: a knowledge document starts with a '---' front matter ({', '.join(REQUIRED)})")
    try:
        end = next(i for i in range(1, len(lines)) if lines[i].strip() == "---")
    except StopIteration:
        raise InputError(f"{where}:1: the front matter has no closing '---'") from None
    try:
        meta = yaml.safe_load("\n".join(lines[1:end])) or {}
    except yaml.YAMLError as exc:
        raise InputError(f"{where}: the front matter is not YAML ({exc})") from None
    if not isinstance(meta, dict):
        raise InputError(f"{where}:2: the front matter is a mapping of {', '.join(REQUIRED)}")
    for name in REQUIRED:
        if meta.get(name) in (None, ""):
            raise InputError(f"{where}:2: the front matter needs {name!r}")
    until = meta["valid_until"]
    if isinstance(until, str):
        try:
            until = dt.date.fromisoformat(until)
        except ValueError:
            raise InputError(f"{where}: valid_until {until!r} is not a date (YYYY-MM-DD)") from None
    if not isinstance(until, dt.date):
        raise InputError(f"{where}: valid_until {until!r} is not a date (YYYY-MM-DD)")
    meta["valid_until"] = until
    return meta, "\n".join(lines[end + 1 :]), end + 2


def chunk(body: str, max_chars: int = MAX_CHARS) -> list[tuple[str, str]]:
    """``(heading path, text)`` pieces: one per section, split at paragraphs past ``max_chars``."""
    out: list[tuple[str, str]] = []
    path: list[str] = []
    paragraphs: list[str] = []

    def close() -> None:
        title = " / ".join(path)
        piece = ""
        for para in paragraphs:
            if piece and len(piece) + len(para) + 2 > max_chars:
                out.append((title, f"{title}\n\n{piece}" if title else piece))
                piece = ""
            piece = f"{piece}\n\n{para}" if piece else para
        if piece:
            out.append((title, f"{title}\n\n{piece}" if title else piece))
        paragraphs.clear()

    for block in re.split(r"\n\s*\n", body):
        block = block.strip()
        m = _HEADING.match(block.splitlines()[0]) if block else None
        if m:
            close()
            level = len(m.group(1))
            path[level - 1 :] = [m.group(2)]
            rest = "\n".join(block.splitlines()[1:]).strip()
            if rest:
                paragraphs.append(rest)
        elif block:
            paragraphs.append(block)
    close()
    return out


def ingest(store: SqliteStore, files: list[Path]) -> list[str]:
    """Ingest every file (all checked before any is written); the keys of the chunks written."""
    docs = []
    for path in files:
        try:
            check_input_file(path, "knowledge document")
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise InputError(f"{path}: cannot read the document ({exc.strerror or exc})") from None
        except UnicodeDecodeError:
            raise InputError(f"{path}: the document is not UTF-8 text") from None
        meta, body, _ = front_matter(text, str(path))
        pieces = chunk(body)
        if not pieces:
            raise InputError(f"{path}: the document has no text after its front matter")
        docs.append((path, meta, pieces))
    written: list[str] = []
    for path, meta, pieces in docs:
        name = _NAME.sub("-", path.stem)
        version = str(meta["version"])
        until: dt.date = meta["valid_until"]
        for old in store.search((ROOT, name), limit=10_000):
            if old.value.get("version") != version:
                store.invalidate((ROOT, name), old.key, f"superseded by version {version}", by="ingest")
        for n, (heading, text) in enumerate(pieces):
            key = f"{name}@{version}#{n}"
            store.put((ROOT, name), key, {
                "text": text, "heading": heading, "source": str(meta["source"]), "file": path.name,
                "version": version, "valid_until": until.isoformat(),
                "valid_until_t": dt.datetime.combine(until, dt.time.max, tzinfo=dt.UTC).timestamp(),
            })  # fmt: skip
            written.append(key)
    return written


def search_knowledge(store: SqliteStore, query: str, *, limit: int = 3, now: float | None = None) -> list[SearchItem]:
    """The chunks most relevant to ``query`` that are still valid (``valid_until`` not passed)."""
    at = dt.datetime.now(dt.UTC).timestamp() if now is None else now
    return store.search((ROOT,), query=query, filter={"valid_until_t": {"$gte": at}}, limit=limit)


__all__ = ["ROOT", "chunk", "front_matter", "ingest", "search_knowledge"]
