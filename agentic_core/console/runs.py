"""The runs of a ``--runs-dir`` as the console lists and replays them: each run's mission, outcome and length
from its ``trace.jsonl``, and a finished (or running) run's events, telemetry, World Models and map, read from its
files so that the page can move through it with a time slider.

>>> import tempfile
>>> list_runs(Path(tempfile.mkdtemp()))
[]
"""

from __future__ import annotations

import json
import re
import sqlite3
from pathlib import Path
from typing import Any

from flight.sim.scene_file import load_scene
from flight.sim.scene_model import Scene

from ..contracts.errors import AgenticUAVError, InputError
from ..mission.validate import load_mission
from .views import mission_view, scene_view, world_view

RUN_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,200}$")
TELEMETRY_POINTS = 5000
"""At most this many telemetry samples go to a replaying page (evenly thinned): a long flight stays light."""
WORLDS = 400


def list_runs(runs_dir: Path) -> list[dict[str, Any]]:
    """Every run folder (one holding ``trace.jsonl``), newest first: id, mission, outcome (``running`` until its
    end event), flight time."""
    if not runs_dir.is_dir():
        return []
    found = []
    for folder in sorted((p for p in runs_dir.iterdir() if (p / "trace.jsonl").is_file()), reverse=True):
        records = _jsonl(folder / "trace.jsonl")
        start = next((r for r in records if r.get("kind") == "run"), {})
        runs = [r for r in records if r.get("kind") == "run"]
        last = runs[-1] if runs else {}  # a run resumed after its end speaks again
        end = last if last.get("event") == "end" else None
        found.append({
            "id": folder.name, "mission": start.get("mission"), "reasoner": start.get("reasoner"),
            "outcome": end.get("outcome") if end else "running", "events": len(records),
            "sim_s": max((r.get("sim_t") or 0.0 for r in records), default=0.0),
        })  # fmt: skip
    return found


def run_folder(runs_dir: Path, run_id: str) -> Path:
    """The folder of ``run_id`` under ``runs_dir``; :class:`InputError` for an id that is not one (no paths)."""
    if not RUN_ID.match(run_id) or not (runs_dir / run_id / "trace.jsonl").is_file():
        raise InputError(f"no run {run_id!r} in {runs_dir}")
    return runs_dir / run_id


def replay(runs_dir: Path, run_id: str) -> dict[str, Any]:
    """One run for the time slider: its map (scene and mission, when their files still load), events,
    telemetry (thinned to :data:`TELEMETRY_POINTS`) and World Models (those of its decisions and of every change
    the map shows, thinned to :data:`WORLDS`), and the checkpoints a fork may start from."""
    folder = run_folder(runs_dir, run_id)
    telemetry = _jsonl(folder / "telemetry.jsonl")
    decided = [world_view(w) for w in _jsonl(folder / "world_models.jsonl")]  # the World Model of each decision
    changes = _jsonl(folder / "world_map.jsonl")  # and whenever what the map shows changed (already cut)
    worlds = _thin(sorted([*decided, *changes], key=lambda w: float(w.get("t") or 0.0)), WORLDS)
    return {
        "run_id": run_id,
        "live": False,
        **_map(folder),
        "events": _jsonl(folder / "trace.jsonl"),
        "telemetry": _thin(telemetry, TELEMETRY_POINTS),
        "worlds": worlds,
        "checkpoints": _checkpoints(folder),
        "forked_from": _origin(folder),
    }


def _map(folder: Path) -> dict[str, Any]:
    """The scene and mission of a run from ``run.json``; nothing when they no longer load (the replay still
    shows the flight and its events)."""
    try:
        mission, scene = _settings(folder)
        home = (scene.home.lat_deg, scene.home.lon_deg) if scene else None
        out: dict[str, Any] = {"mission": mission_view(load_mission(mission, home=home), home)}
        if scene is not None:
            out["scene"] = scene_view(scene)
        return out
    except (OSError, KeyError, TypeError, ValueError, AgenticUAVError):
        return {}


def run_scene(runs_dir: Path, run_id: str) -> Scene | None:
    """The scene ``run_id`` flew in, from its ``run.json``; ``None`` when it has none or it no longer loads;
    :class:`InputError` for an id that is not a run."""
    folder = run_folder(runs_dir, run_id)
    try:
        return _settings(folder)[1]
    except (OSError, KeyError, TypeError, ValueError, AgenticUAVError):
        return None


def _settings(folder: Path) -> tuple[Path, Scene | None]:
    from ..run.settings import default_scene  # here: the run's settings import its report's plotting (seconds)

    settings = json.loads((folder / "run.json").read_text(encoding="utf-8"))["settings"]
    mission = Path(settings["mission"])
    scene_file = Path(settings["scene"]) if settings.get("scene") else default_scene(mission)
    return mission, load_scene(scene_file) if scene_file else None


def _checkpoints(folder: Path) -> list[dict[str, Any]]:
    """The graph's checkpoints, each with the vehicle's clock at the time: where a fork may start."""
    from ..run.fork import checkpoints, marks_json

    try:
        return marks_json(checkpoints(folder, folder.name))
    except (AgenticUAVError, OSError, sqlite3.Error):
        return []


def _origin(folder: Path) -> dict[str, Any] | None:
    try:
        origin = json.loads((folder / "run.json").read_text(encoding="utf-8")).get("forked_from")
    except (OSError, ValueError, AttributeError):
        return None
    return origin if isinstance(origin, dict) else None


def _jsonl(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    out = []
    for line in path.read_text(encoding="utf-8", errors="replace").splitlines():
        try:
            item = json.loads(line)
        except json.JSONDecodeError:  # a line cut by a kill, or still being written
            continue
        if isinstance(item, dict):
            out.append(item)
    return out


def _thin(items: list[dict[str, Any]], most: int) -> list[dict[str, Any]]:
    if len(items) <= most:
        return items
    step = len(items) / most
    return [items[int(i * step)] for i in range(most)] + [items[-1]]


__all__ = ["list_runs", "replay", "run_folder", "run_scene"]
