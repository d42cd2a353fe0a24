"""Bounded reads of a run's files for the console: a JSON Lines file up to a byte budget (a line cut by a kill
skipped, an overlong one dropped, and, asked for, only about ``keep`` lines parsed, evenly spread), and a small
JSON file refused past its size; each says what it could not read instead of raising.

>>> import tempfile
>>> path = Path(tempfile.mkdtemp()) / "x.jsonl"
>>> _ = path.write_text('{"a": 1}\\n{"a": 2\\n[3]\\n', encoding="utf-8")
>>> read_jsonl(path, 1000)
([{'a': 1}], None)
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

LINE_BYTES = 1_000_000
"""A line longer than this is not one of ours: dropped unread."""
TYPICAL_LINE = 400
"""Bytes a telemetry line takes about (they take 400 to 600): how far apart to parse when only some are kept."""


def read_jsonl(path: Path, most_bytes: int, *, keep: int | None = None) -> tuple[list[dict[str, Any]], str | None]:
    """The objects of ``path``'s lines within its first ``most_bytes`` (none for a missing file), and what was
    left out (``None``: nothing). With ``keep``, about every k-th line is parsed so that roughly ``keep`` and at
    least the last are."""
    out: list[dict[str, Any]] = []
    problem = None
    try:
        size = path.stat().st_size
        every = max(1, min(size, most_bytes) // TYPICAL_LINE // keep) if keep else 1
        with path.open("rb") as lines:
            read, index, last = 0, 0, b""
            while True:
                line = lines.readline(LINE_BYTES + 1)
                if not line:
                    break
                read += len(line)
                if read > most_bytes:
                    problem = f"{path.name}: read only its first {most_bytes} bytes"
                    break
                if len(line) > LINE_BYTES and not line.endswith(b"\n"):
                    while line and not line.endswith(b"\n") and read <= most_bytes:
                        line = lines.readline(LINE_BYTES + 1)
                        read += len(line)
                    problem = f"{path.name}: a line over {LINE_BYTES} bytes dropped"
                    continue
                index += 1
                last = line
                if index % every == 1 or every == 1:
                    _add(out, line)
            if every > 1 and last and index % every != 1:
                _add(out, last)
    except FileNotFoundError:
        return [], None
    except OSError as exc:
        return out, f"{path.name}: {exc.strerror or exc}"
    return out, problem


def _add(out: list[dict[str, Any]], line: bytes) -> None:
    try:
        item = json.loads(line)
    except (json.JSONDecodeError, UnicodeDecodeError):  # cut by a kill, or still being written
        return
    if isinstance(item, dict):
        out.append(item)


def read_json(path: Path, most_bytes: int) -> tuple[dict[str, Any], str | None]:
    """The JSON object in ``path`` (``{}`` when it is missing, larger than ``most_bytes``, not JSON or not an
    object) and what was wrong with it."""
    try:
        if path.stat().st_size > most_bytes:
            return {}, f"{path.name}: larger than {most_bytes} bytes"
        item = json.loads(path.read_bytes())
    except FileNotFoundError:
        return {}, f"{path.name}: missing"
    except OSError as exc:
        return {}, f"{path.name}: {exc.strerror or exc}"
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        return {}, f"{path.name}: not JSON ({exc})"
    if not isinstance(item, dict):
        return {}, f"{path.name}: not a JSON object"
    return item, None


__all__ = ["read_json", "read_jsonl"]
