"""Campaigns the console shows: each directory under its ``--campaigns-dir`` (by default its runs folder) holding a
``progress.json`` (:class:`~agentic_core.contracts.campaign_progress.CampaignProgress`, written by ``agentic-uav
eval campaign`` as it goes), with its counts, rates and time left. Read from the files only: a campaign runs in
its own process, and the console may not import ``evaluation``.

>>> import tempfile
>>> list_campaigns(Path(tempfile.mkdtemp()))
[]
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..contracts.campaign_progress import PROGRESS_FILE, CampaignProgress, seems_stalled

MOST_BYTES = 1_000_000
"""A progress file larger than this is not one (it is read whole)."""


def list_campaigns(directory: Path) -> list[dict[str, Any]]:
    """Every campaign under ``directory`` (itself, or a folder in it), newest first; a progress file that cannot
    be read is listed with its error, never fatal."""
    if not directory.is_dir():
        return []
    candidates = [directory / PROGRESS_FILE, *(p / PROGRESS_FILE for p in directory.iterdir() if p.is_dir())]
    found = []
    now = time.time()
    for path in candidates:
        if not path.is_file():
            continue
        try:
            if path.stat().st_size > MOST_BYTES:
                raise ValueError(f"larger than {MOST_BYTES} bytes")
            progress = CampaignProgress.model_validate_json(path.read_bytes())
        except (OSError, ValueError, ValidationError) as exc:
            error = exc.errors()[0]["msg"] if isinstance(exc, ValidationError) else str(exc)
            found.append({"campaign": path.parent.name, "error": f"{path.name}: {error}", "updated_at": 0.0})
            continue
        state: str = "stalled" if seems_stalled(progress, now) else progress.state
        if state == "ended":
            state = "completed" if progress.done >= progress.total else "stopped"
        found.append({**progress.model_dump(mode="json"), "campaign": path.parent.name, "state": state})
    return sorted(found, key=lambda c: -float(c.get("updated_at") or 0.0))


__all__ = ["list_campaigns"]
