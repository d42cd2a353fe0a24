"""Alert attachments named by what they are (``snapshot``, ``world_model``, ``position``, ``assessment``) turned
into files of the run, so ``alerts.notify`` attaches real files and a reader of the alert sees what the agent saw.

A mission writes ``attach: [position, snapshot, world_model]``; the runner calls :func:`materialize` on the
arguments of every ``alerts.notify`` call before it reaches the tool. Paths that are already files pass through;
a name that cannot be produced (no frame yet) is passed on as it is, so the alert lists it as unavailable.

This is on the way from the frame that confirms a casualty to the alert sent, so it is kept quick: the World
Model is written by pydantic's serialiser (:meth:`WorldModel.to_json`; the standard library's indenting encoder is
pure Python and took several milliseconds for a crowd), and the picture is drawn without matplotlib's figures
(:mod:`agentic_core.perception.annotate`).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..perception.world_model import WorldModel
from .perception_loop import PerceptionLoop
from .readable import rounded

SYMBOLIC = ("snapshot", "world_model", "position", "assessment")


def materialize(
    args: Mapping[str, Any],
    *,
    out_dir: Path,
    stamp: str,
    loop: PerceptionLoop | None,
    position: Callable[[], dict[str, Any] | None],
    last_decision: Callable[[], dict[str, Any] | None],
) -> dict[str, Any]:
    """``args`` with each symbolic attachment replaced by the file written for it under ``out_dir``."""
    attach = list(args.get("attach") or [])
    if not attach:
        return dict(args)
    out_dir.mkdir(parents=True, exist_ok=True)
    files: list[str] = []
    for item in attach:
        path = _produce(item, out_dir / stamp, loop, position, last_decision)
        files.append(str(path) if path is not None else item)
    return {**args, "attach": files}


def _produce(
    item: str,
    base: Path,
    loop: PerceptionLoop | None,
    position: Callable[[], dict[str, Any] | None],
    last_decision: Callable[[], dict[str, Any] | None],
) -> Path | None:
    if item == "snapshot":
        return loop.snapshot(base.with_name(base.name + "-snapshot.png")) if loop is not None else None
    if item == "world_model":
        world: WorldModel | None = loop.world if loop is not None else None
        if world is None:
            return None
        path = base.with_name(base.name + "-world_model.json")
        path.write_text(world.to_json(indent=2) + "\n", encoding="utf-8")  # indented like _json, ten times faster
        return path
    if item == "position":
        return _json(base.with_name(base.name + "-position.json"), rounded(position()))
    if item == "assessment":
        return _json(base.with_name(base.name + "-assessment.json"), last_decision())
    return None


def _json(path: Path, data: Any) -> Path | None:
    if data is None:
        return None
    path.write_text(json.dumps(data, indent=2, ensure_ascii=False, default=str) + "\n", encoding="utf-8")
    return path


__all__ = ["SYMBOLIC", "materialize"]
