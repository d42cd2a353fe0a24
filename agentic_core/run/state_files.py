"""What a run keeps on disk to be resumed: ``run.json`` (its settings and id, written at the start) and
``snapshot.json`` (the simulated vehicle and the World Model, rewritten atomically after every superstep and every
completed tool call). A killed run is continued from these and its graph checkpoint (``checkpoints.db``).
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..contracts import InputError
from ..contracts.errors import field_problem
from ..perception.tracker import TrackerState
from .settings import RunSettings

RUN_FILE = "run.json"
SNAPSHOT_FILE = "snapshot.json"
VEHICLES_FILE = "vehicles.jsonl"
VEHICLES_KEPT = 1000
"""The simulated vehicle's states kept in ``vehicles.jsonl`` at most (about 4 KB each): what a fork starts from."""


class ForkOrigin(BaseModel):
    """Where a forked run came from: a run and one of its graph checkpoints, at a time of the vehicle's clock."""

    model_config = ConfigDict(extra="forbid")

    run_id: str
    checkpoint_id: str
    step: int
    sim_t: float | None = None


class RunRecord(BaseModel):
    """``run.json``: what a run was started with."""

    model_config = ConfigDict(extra="forbid")

    run_id: str
    settings: RunSettings
    forked_from: ForkOrigin | None = None
    """Set for a fork: the run and checkpoint it started from (the original is never changed)."""


class Snapshot(BaseModel):
    """``snapshot.json``: the state outside the graph that a resumed run needs."""

    model_config = ConfigDict(extra="forbid")

    vehicle: dict[str, Any] | None = None
    world: dict[str, Any] | None = None
    last_seen: dict[str, tuple[float, float, str, float]] = Field(default_factory=dict)
    """Where each object was last seen (lat, lon, class, time): targets a resumed run can still fly to."""
    tracks: TrackerState | None = None
    """The tracker's tracks: a resumed run goes on tracking the same people under the same ids."""
    first_detected: dict[str, float] = Field(default_factory=dict)
    """When each of the scene's actors was first detected: a resumed run's report keeps the first sighting."""
    sim_t: float | None = None


def write_record(run_dir: Path, record: RunRecord) -> None:
    """``run.json``, every file the settings name anchored (:func:`anchored`)."""
    record = record.model_copy(update={"settings": anchored(record.settings)})
    atomic_write(run_dir / RUN_FILE, record.model_dump_json(indent=2))


def anchored(settings: RunSettings) -> RunSettings:
    """``settings`` with the files they name (mission, scene, gains, signing key, memory, tool files, an ``onnx:``
    detector) made absolute, so ``--resume`` finds them from any folder (a module name stays as written).

    >>> anchored(RunSettings(mission=Path("m.yaml"))).mission.is_absolute()
    True
    """

    def file(path: Path | None) -> Path | None:
        return None if path is None else path.expanduser().absolute()

    tools = [str(Path(t).absolute()) if Path(t).exists() else t for t in settings.tools]
    detector = settings.detector
    if detector.startswith("onnx:"):
        detector = f"onnx:{Path(detector[5:]).expanduser().absolute()}"
    return settings.model_copy(
        update={
            "mission": file(settings.mission), "scene": file(settings.scene), "gains": file(settings.gains),
            "signing_key": file(settings.signing_key), "memory": file(settings.memory), "tools": tools,
            "detector": detector,
        }
    )  # fmt: skip


def read_record(runs_dir: Path, run_id: str) -> RunRecord:
    """The record of a run to resume; :class:`InputError` naming what is missing or broken."""
    if not run_id or "/" in run_id or run_id in (".", ".."):
        raise InputError(f"--resume {run_id!r}: not a run id")
    path = runs_dir / run_id / RUN_FILE
    if not path.is_file():
        raise InputError(f"--resume {run_id}: {path} does not exist (is --runs-dir right?)")
    try:
        return RunRecord.model_validate_json(path.read_bytes())
    except ValidationError as exc:
        raise InputError(f"{path}: {field_problem(exc)}") from None


def read_snapshot(run_dir: Path) -> Snapshot | None:
    """The last snapshot, or None when the run never wrote one (killed before its first step)."""
    path = run_dir / SNAPSHOT_FILE
    if not path.is_file():
        return None
    try:
        return Snapshot.model_validate_json(path.read_bytes())
    except ValidationError as exc:
        raise InputError(f"{path}: not a snapshot: {exc.errors()[0]['msg']}") from None


class SnapshotWriter:
    """Writes ``snapshot.json`` atomically (a kill mid-write leaves the previous one); thread-safe. Each new
    state of the simulated vehicle (a new time on its clock) is also appended to ``vehicles.jsonl``, up to
    :data:`VEHICLES_KEPT`, stamped with the wall time, so a fork from an earlier checkpoint finds the vehicle
    as it was then."""

    def __init__(self, run_dir: Path) -> None:
        self.path = run_dir / SNAPSHOT_FILE
        self.history = run_dir / VEHICLES_FILE
        self._lock = threading.Lock()
        self.written = 0
        kept = read_jsonl(self.history)
        self._kept = len(kept)
        self._last_sim_t = kept[-1].get("sim_t") if kept else None

    def write(self, snapshot: Snapshot) -> None:
        with self._lock:
            atomic_write(self.path, snapshot.model_dump_json())
            self.written += 1
            if snapshot.vehicle is not None and snapshot.sim_t != self._last_sim_t and self._kept < VEHICLES_KEPT:
                line = {"t": round(time.time(), 6), "sim_t": snapshot.sim_t, "vehicle": snapshot.vehicle}
                with self.history.open("a", encoding="utf-8") as out:
                    out.write(json.dumps(line, separators=(",", ":")) + "\n")
                self._kept += 1
                self._last_sim_t = snapshot.sim_t


def atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` so that a kill mid-write leaves the old file, never a torn one (a temporary
    file beside it, synced, then renamed over it)."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.tmp")
    with tmp.open("w", encoding="utf-8") as out:
        out.write(text)
        out.flush()
        os.fsync(out.fileno())
    os.replace(tmp, path)


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """The records of a JSON-lines file; a last line cut short by a kill is passed over."""
    if not path.is_file():
        return []
    out: list[dict[str, Any]] = []
    for line in path.read_text(encoding="utf-8").splitlines():
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(record, dict):
            out.append(record)
    return out


__all__ = [
    "VEHICLES_FILE",
    "ForkOrigin",
    "RunRecord",
    "Snapshot",
    "SnapshotWriter",
    "anchored",
    "atomic_write",
    "read_jsonl",
    "read_record",
    "read_snapshot",
    "write_record",
]
