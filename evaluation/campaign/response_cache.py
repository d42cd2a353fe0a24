"""``model_cache.jsonl``: a campaign's model answers, appended as jobs finish, read back for a replay.

One :class:`~evaluation.campaign.model_calls.ResponseEntry` per line. The file is checked before it is read (a
regular file within ``AGENTIC_UAV_MAX_INPUT_MB``). A torn last line (a campaign killed while writing it) is skipped;
any other bad line is an error naming it.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from pydantic import ValidationError

from agentic_core.contracts.input_files import InputFileError, check_input_file

from .model_calls import ResponseEntry


def append_responses(path: Path, entries: Sequence[ResponseEntry]) -> None:
    """Append ``entries`` and make them durable; nothing (not even the file) when there are none."""
    if not entries:
        return
    with path.open("a", encoding="utf-8") as fh:
        fh.write("".join(e.model_dump_json() + "\n" for e in entries))
        fh.flush()
        os.fsync(fh.fileno())


def load_responses(path: Path) -> dict[str, list[ResponseEntry]]:
    """The entries of ``path`` by scene id; ``ValueError`` naming the file and line of a bad entry, ``OSError``
    when the file cannot be read (a campaign without one called no model: there is nothing to replay)."""
    if not path.exists():
        raise ValueError(f"{path.name} not found: the campaign called no model, or is not a campaign directory")
    try:
        check_input_file(path, "model cache")
    except InputFileError as exc:
        raise ValueError(f"{path}: {exc.reason}") from None
    raw = path.read_text(encoding="utf-8")
    lines = raw.split("\n")
    out: dict[str, list[ResponseEntry]] = {}
    for number, line in enumerate(lines, start=1):
        if not line.strip():
            continue
        try:
            entry = ResponseEntry.model_validate_json(line)
        except ValidationError as exc:
            if number == len(lines) and not raw.endswith("\n"):
                break
            raise ValueError(f"{path}, line {number}: not a cached model response ({exc.errors()[0]['msg']})") from None
        out.setdefault(entry.scene_id, []).append(entry)
    return out


__all__ = ["append_responses", "load_responses"]
