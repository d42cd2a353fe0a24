"""Forking a run from one of its graph checkpoints: a new run whose graph starts where the original's stood at
that checkpoint, with the original's files up to that moment (trace, telemetry, World Models, the vehicle as it was
then), its origin in ``run.json`` (``forked_from``) and in its trace (a ``run`` event ``fork``). The original is
only read: its checkpoint database is read from a copy. The fork flies with ``agentic-uav run --resume NEW_ID``.

>>> import tempfile
>>> try:
...     fork_run(Path(tempfile.mkdtemp()), "../elsewhere", "c1")
... except InputError as exc:
...     print(exc)
fork: '../elsewhere' is not a run id
"""

from __future__ import annotations

import json
import re
import shutil
import sqlite3
import tempfile
from collections.abc import Iterator
from contextlib import closing, contextmanager
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..contracts import InputError
from ..contracts.events import RunEvent
from .state_files import (
    VEHICLES_FILE,
    ForkOrigin,
    RunRecord,
    Snapshot,
    atomic_write,
    read_jsonl,
    read_record,
    write_record,
)
from .world_map import WORLD_MAP_FILE

CHECKPOINTS_FILE = "checkpoints.db"
RUN_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,200}$")
"""A run id is a folder name, never a path."""


@dataclass(frozen=True)
class CheckpointMark:
    """One checkpoint of a run's graph (top level), and when it was taken: wall time and the vehicle's clock."""

    id: str
    step: int
    t: float
    sim_t: float | None
    seq: int


def checkpoints(run_dir: Path, run_id: str) -> list[CheckpointMark]:
    """The graph's checkpoints of the run in ``run_dir``, oldest first, each with the vehicle's clock at the time
    (the last trace event written before it); ``[]`` when there is no database."""
    with _read_only(run_dir / CHECKPOINTS_FILE) as conn:
        if conn is None:
            return []
        rows = conn.execute(
            "SELECT checkpoint_id, step, created_at, seq FROM agentic_checkpoints WHERE thread_id = ? AND ns = ''"
            " ORDER BY seq",
            (run_id,),
        ).fetchall()
    timeline = [(float(r["t"]), r.get("sim_t")) for r in read_jsonl(run_dir / "trace.jsonl")
                if isinstance(r.get("t"), (int, float))]  # fmt: skip
    marks, k, sim_t = [], 0, None
    for checkpoint_id, step, created_at, seq in rows:
        while k < len(timeline) and timeline[k][0] <= created_at:
            sim_t = timeline[k][1] if timeline[k][1] is not None else sim_t
            k += 1
        marks.append(CheckpointMark(str(checkpoint_id), int(step), float(created_at), sim_t, int(seq)))
    return marks


def fork_run(runs_dir: Path, run_id: str, checkpoint_id: str, *, new_id: str | None = None) -> str:
    """Fork ``run_id`` of ``runs_dir`` at ``checkpoint_id`` into a new run folder; returns its id.
    :class:`InputError` for a run or checkpoint that is not there (nothing is written then)."""
    if not RUN_ID.match(run_id):
        raise InputError(f"fork: {run_id!r} is not a run id")
    record = read_record(runs_dir, run_id)
    source = runs_dir / run_id
    mark = next((m for m in checkpoints(source, record.run_id) if m.id == checkpoint_id), None)
    if mark is None:
        raise InputError(f"fork: run {run_id} has no checkpoint {checkpoint_id!r}")
    vehicle = _vehicle_at(source, mark, simulated=record.settings.connect is None)
    new_id = new_id or _fresh_id(runs_dir, f"{run_id[:150]}-fork{mark.step}")
    if not RUN_ID.match(new_id):
        raise InputError(f"fork: {new_id!r} is not a run id")
    target = runs_dir / new_id
    target.mkdir()
    try:
        _copy_checkpoints(source / CHECKPOINTS_FILE, target / CHECKPOINTS_FILE, record.run_id, new_id, mark)
        _copy_files(source, target, mark, vehicle)
        origin = ForkOrigin(run_id=record.run_id, checkpoint_id=mark.id, step=mark.step, sim_t=mark.sim_t)
        write_record(target, RunRecord(run_id=new_id, settings=record.settings, forked_from=origin))
    except BaseException:
        shutil.rmtree(target, ignore_errors=True)
        raise
    return new_id


def _vehicle_at(run_dir: Path, mark: CheckpointMark, *, simulated: bool) -> dict[str, Any] | None:
    """The simulated vehicle as it was at ``mark``: the state recorded right after that checkpoint (the run
    records one after every superstep), else the last one before it."""
    if not simulated:
        return None  # a vehicle of its own keeps its state: the fork re-attaches to it
    states = read_jsonl(run_dir / VEHICLES_FILE)
    after = next((s for s in states if float(s.get("t", 0.0)) >= mark.t), None)
    before = [s for s in states if float(s.get("t", 0.0)) < mark.t]
    chosen = after if after is not None and (mark.sim_t is None or after.get("sim_t") == mark.sim_t) else None
    chosen = chosen or (before[-1] if before else after)
    if chosen is None or not isinstance(chosen.get("vehicle"), dict):
        raise InputError(f"fork: {run_dir.name} kept no vehicle state near checkpoint {mark.id} ({VEHICLES_FILE})")
    return dict(chosen)


def _copy_files(source: Path, target: Path, mark: CheckpointMark, vehicle: dict[str, Any] | None) -> None:
    sim_t = mark.sim_t if mark.sim_t is not None else 0.0
    events = [r for r in read_jsonl(source / "trace.jsonl") if float(r.get("t", 0.0)) <= mark.t]
    seq = max((int(r.get("seq", 0)) for r in events), default=0) + 1
    fork = RunEvent(
        kind="run",
        seq=seq,
        sim_t=mark.sim_t,
        event="fork",
        forked_from=source.name,
        checkpoint=mark.id,
        summary=f"fork of {source.name} at checkpoint {mark.step} ({sim_t:.1f} s)",
    )
    _write_jsonl(target / "trace.jsonl", [*events, fork.model_dump(mode="json")])
    _write_jsonl(
        target / "telemetry.jsonl",
        [r for r in read_jsonl(source / "telemetry.jsonl") if float(r.get("time_s", 0.0)) <= sim_t + 1e-6],
    )
    worlds = [r for r in read_jsonl(source / "world_models.jsonl") if float(r.get("timestamp", 0.0)) <= sim_t + 1e-6]
    _write_jsonl(target / "world_models.jsonl", worlds)
    changes = [r for r in read_jsonl(source / WORLD_MAP_FILE) if float(r.get("t") or 0.0) <= sim_t + 1e-6]
    _write_jsonl(target / WORLD_MAP_FILE, changes)
    if vehicle is not None:
        _write_jsonl(target / VEHICLES_FILE, [vehicle])
    snapshot = Snapshot(vehicle=vehicle["vehicle"] if vehicle else None, world=worlds[-1] if worlds else None,
                        sim_t=vehicle.get("sim_t") if vehicle else mark.sim_t)  # fmt: skip
    atomic_write(target / "snapshot.json", snapshot.model_dump_json())


def _copy_checkpoints(source: Path, target: Path, run_id: str, new_id: str, mark: CheckpointMark) -> None:
    """The checkpoints up to ``mark`` under the new run's thread; the outcomes of the tasks that ran after it are
    left out, so the fork runs them again."""
    with _read_only(source) as conn, closing(sqlite3.connect(str(target), isolation_level=None)) as out:
        if conn is None:
            raise InputError(f"fork: {source} is gone")
        conn.backup(out)
        out.execute("BEGIN")
        out.execute("DELETE FROM agentic_checkpoints WHERE thread_id != ? OR seq > ?", (run_id, mark.seq))
        out.execute("DELETE FROM agentic_writes WHERE thread_id != ? OR checkpoint_id = ? OR checkpoint_id NOT IN "
                    "(SELECT checkpoint_id FROM agentic_checkpoints)", (run_id, mark.id))  # fmt: skip
        out.execute("UPDATE agentic_checkpoints SET thread_id = ?", (new_id,))
        out.execute("UPDATE agentic_writes SET thread_id = ?", (new_id,))
        out.execute("COMMIT")
        out.execute("VACUUM")


@contextmanager
def _read_only(path: Path) -> Iterator[sqlite3.Connection | None]:
    """The database at ``path``, read from a copy (with its write-ahead log): opening the original, even
    read-only, would leave files beside it, and a run still writing it is never disturbed."""
    if not path.is_file():
        yield None
        return
    with tempfile.TemporaryDirectory(prefix="agentic-fork-") as scratch:
        copy = Path(scratch) / path.name
        shutil.copyfile(path, copy)
        wal = path.with_name(path.name + "-wal")
        if wal.is_file():
            shutil.copyfile(wal, copy.with_name(copy.name + "-wal"))
        conn = sqlite3.connect(str(copy))
        try:
            yield conn
        except sqlite3.DatabaseError as exc:
            raise InputError(f"fork: {path}: {exc}") from None
        finally:
            conn.close()


def _fresh_id(runs_dir: Path, base: str) -> str:
    name, n = base, 1
    while (runs_dir / name).exists():
        n += 1
        name = f"{base}-{n}"
    return name


def _write_jsonl(path: Path, records: list[dict[str, Any]]) -> None:
    path.write_text("".join(json.dumps(r, separators=(",", ":")) + "\n" for r in records), encoding="utf-8")


def marks_json(marks: list[CheckpointMark]) -> list[dict[str, Any]]:
    """The checkpoints as the console's time slider takes them."""
    return [{k: v for k, v in asdict(m).items() if k != "seq"} for m in marks]


__all__ = ["CHECKPOINTS_FILE", "CheckpointMark", "checkpoints", "fork_run", "marks_json"]
