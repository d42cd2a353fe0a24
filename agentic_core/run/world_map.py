"""``world_map.jsonl``: the World Model as the console's replay draws it (each object's class, confidence, state,
position and covariance; the ``near`` and ``isolated_from`` relations), written whenever what it shows changes, at
most once per :data:`PERIOD_S` of the vehicle's clock, :data:`MOST` times and :data:`MOST_BYTES` a run.
``world_models.jsonl`` keeps the whole World Model of each decision only: whole models on every change would be
megabytes a minute.

>>> import tempfile
>>> from agentic_core.contracts.world_model import WorldModel
>>> log = WorldMapLog(Path(tempfile.mkdtemp()) / "world_map.jsonl")
>>> pose = {"north": 0, "east": 0, "down": 0, "lat": 21.4, "lon": 39.9, "alt": 0}
>>> person = {"id": "P-1", "class": "person", "pose": pose, "conf": 0.9}
>>> log(WorldModel.model_validate({"timestamp": 1.0, "frame": 1, "ego_pose": pose, "objects": [person]}))
>>> log(WorldModel.model_validate({"timestamp": 1.2, "frame": 2, "ego_pose": pose}))  # within the period
>>> [len(r["objects"]) for r in read_jsonl(log.path)]
[1]
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..contracts.world_model import WorldModel
from .state_files import read_jsonl

WORLD_MAP_FILE = "world_map.jsonl"
PERIOD_S = 1.0
"""At most one record per this many seconds of the vehicle's clock."""
MOST = 3000
"""Records a run keeps at most (a resumed run counts what it wrote before)."""
MOST_BYTES = 20_000_000
"""Bytes a run's file may reach at most (a crowd of a thousand is about 130 KB a record)."""
MOVED_M = 1.0
"""An object that moved less than about this far has not changed on the map."""
SHOWN = ("near", "isolated_from")


class WorldMapLog:
    """A perception hook (``PerceptionLoop.on_world``): appends the map's view of a World Model that changed."""

    def __init__(
        self, path: Path, *, period_s: float = PERIOD_S, most: int = MOST, most_bytes: int = MOST_BYTES
    ) -> None:
        self.path = path
        self.period_s = period_s
        self.most = most
        self.most_bytes = most_bytes
        kept = read_jsonl(path)
        self.written = len(kept)
        self.bytes = path.stat().st_size if path.is_file() else 0
        self._last_t = float(kept[-1].get("t") or 0.0) if kept else None
        self._last: tuple[Any, ...] | None = None

    def __call__(self, world: WorldModel) -> None:
        t = float(world.timestamp)
        if (
            self.written >= self.most
            or self.bytes >= self.most_bytes
            or (self._last_t is not None and 0.0 <= t - self._last_t < self.period_s)
        ):
            return
        self._last_t = t  # looked at: the next look is a period on, changed or not (a still scene costs nothing)
        shape = _shape(world)
        if shape == self._last:
            return
        self._last = shape
        line = json.dumps(map_view(world), separators=(",", ":")) + "\n"
        with self.path.open("a", encoding="utf-8") as out:
            out.write(line)
        self.written += 1
        self.bytes += len(line.encode("utf-8"))


def map_view(world: WorldModel) -> dict[str, Any]:
    """What the map draws of ``world`` (the shape of ``agentic_core.console.views.world_view``), rounded."""
    objects = [
        {"id": o.id, "class": o.class_name, "conf": round(o.conf, 3), "state": o.state,
         "lat": round(o.pose.lat, 7), "lon": round(o.pose.lon, 7),
         "cov": [[round(v, 3) for v in row] for row in o.cov], "stationary_s": round(o.stationary_s, 1)}
        for o in world.objects
    ]  # fmt: skip
    relations = [{"subj": r.subj, "pred": r.pred, "obj": r.obj} for r in world.relations if r.pred in SHOWN]
    return {"t": world.timestamp, "objects": objects, "relations": relations}


def _shape(world: WorldModel) -> tuple[Any, ...]:
    """What the map shows, coarsely: a change in any of it is a change worth a record."""
    step = MOVED_M / 111_320.0
    objects = tuple(
        (o.id, o.class_name, o.state, round(o.pose.lat / step), round(o.pose.lon / step)) for o in world.objects
    )
    relations = tuple((r.subj, r.pred, r.obj) for r in world.relations if r.pred in SHOWN)
    return objects, relations


__all__ = ["MOST", "MOST_BYTES", "PERIOD_S", "WORLD_MAP_FILE", "WorldMapLog", "map_view"]
