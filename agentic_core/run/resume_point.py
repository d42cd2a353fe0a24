"""Whether and where a run can go on, decided before anything is sent to its aircraft: one process at a time in a
run's folder (:class:`RunHold`), and a graph checkpoint that can be read (:func:`resume_point`).

Why: two resumes of one run flew one aircraft from one folder and disagreed on the outcome; a corrupt
``checkpoints.db`` was found only after the fence had been sent, and the run then stopped with its aircraft in the
air; a run killed before its first checkpoint could not be resumed at all.

>>> import tempfile
>>> from pathlib import Path
>>> folder = Path(tempfile.mkdtemp())
>>> hold = RunHold.take(folder, "demo", "flown")
>>> try:
...     RunHold.take(folder, "demo", "resumed")
... except InputError as refused:
...     print(str(refused).split(" by pid")[0])
run demo is already being flown
>>> hold.release()
>>> resume_point(folder, "demo", [])
False
"""

from __future__ import annotations

import fcntl
import os
import sqlite3
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO

from ..contracts import InputError
from ..graph.checkpoint.sqlite import SqliteSaver
from .state_files import Snapshot, read_jsonl, read_snapshot

LOCK_FILE = "run.lock"
"""The file a run's process holds an exclusive ``flock`` on while it flies (the kernel lets go when it dies)."""
CHECKPOINTS_FILE = "checkpoints.db"
SQLITE_HEADER = b"SQLite format 3\x00"


class RunHold:
    """An exclusive lock on a run's folder, held by the one process flying or resuming it; released at
    :meth:`release`, when the hold is garbage, or, on ``kill -9``, by the kernel, so a crashed run never blocks
    the next resume."""

    def __init__(self, file: BinaryIO) -> None:
        self._file: BinaryIO | None = file

    @classmethod
    def take(cls, run_dir: Path, run_id: str, doing: str) -> RunHold:
        """Hold ``run_dir`` (``doing``: ``flown`` or ``resumed``, for the refusal another process gets);
        :class:`InputError` at once when another process holds it."""
        path = run_dir / LOCK_FILE
        try:
            file = os.fdopen(os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600), "r+b")
        except OSError as exc:
            raise InputError(f"{path}: cannot open the run's lock file: {exc.strerror}") from None
        try:
            fcntl.flock(file.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = _holder(file.read(200))
            file.close()
            raise InputError(
                f"run {run_id} is already being {holder} (its folder {run_dir} is locked): wait for it to end, "
                "or stop it, before resuming it"
            ) from None
        file.truncate(0)
        file.write(f"{os.getpid()} {doing}\n".encode())
        file.flush()
        return cls(file)

    def release(self) -> None:
        """Let go of the folder (safe to call twice)."""
        if self._file is not None:
            file, self._file = self._file, None
            file.close()  # closing the descriptor drops the flock

    @staticmethod
    def drop(hold: RunHold | None) -> None:
        """Release ``hold``, if there is one."""
        if hold is not None:
            hold.release()


def _holder(text: bytes) -> str:
    """``flown by pid N`` (or ``resumed by``), as the holder wrote it in the lock file."""
    words = text.decode(errors="replace").split()
    if len(words) >= 2 and words[0].isdigit():
        return f"{words[1]} by pid {words[0]}"
    return "flown by another process"


@dataclass
class Resumption:
    """A run about to be resumed: its folder held, where its graph goes on from, and its snapshot."""

    hold: RunHold | None = None
    from_start: bool = False
    """True when the run was killed before its first checkpoint: its mission starts again from the beginning."""
    snapshot: Snapshot | None = None


def open_resume(run_dir: Path, run_id: str) -> Resumption:
    """Hold the folder of the run to resume and read what it goes on from, before anything is sent to its
    aircraft; :class:`InputError`, the folder let go, when it cannot be resumed."""
    hold = RunHold.take(run_dir, run_id, "resumed")
    try:
        from_start = not resume_point(run_dir, run_id, read_jsonl(run_dir / "trace.jsonl"))
        return Resumption(hold, from_start, read_snapshot(run_dir))
    except BaseException:
        hold.release()
        raise


def resume_point(run_dir: Path, run_id: str, records: Sequence[Mapping[str, Any]]) -> bool:
    """Whether ``checkpoints.db`` holds a checkpoint of the run's graph to go on from (True); False when the run
    was killed before its first one and its trace shows no step begun, so it starts again from the beginning.
    :class:`InputError` naming the file when it is not a readable checkpoint database, or holds no checkpoint
    though ``records`` (the run's trace) show its mission under way."""
    path = run_dir / CHECKPOINTS_FILE
    found = _checkpoints(path, run_id) if path.exists() else 0
    if found:
        return True
    if _mission_begun(records):
        raise InputError(
            f"{path}: holds no checkpoint of run {run_id}, though its trace shows the mission under way: the run "
            "cannot go on from where it was (fork it from an earlier run, or start the mission again)"
        )
    return False


def _checkpoints(path: Path, run_id: str) -> int:
    """How many checkpoints of ``run_id``'s graph ``path`` holds, the newest read through as a resume reads it."""
    if not path.is_file():
        raise InputError(f"{path}: not a file: the run cannot be resumed from it")
    if path.stat().st_size == 0:
        return 0
    with path.open("rb") as f:
        if f.read(len(SQLITE_HEADER)) != SQLITE_HEADER:  # a WAL beside it would otherwise hide a damaged file
            return _not_ours(path, "it is not an SQLite file")
    try:
        conn = sqlite3.connect(path, isolation_level=None)
        try:
            check = conn.execute("PRAGMA quick_check").fetchall()
            if check != [("ok",)]:
                raise InputError(f"{path}: the checkpoint database is damaged ({check[0][0]}): it cannot be resumed")
            tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if "agentic_checkpoints" not in tables:
                return 0 if not tables else _not_ours(path, "it has no checkpoints table")
            row = conn.execute("SELECT COUNT(*) FROM agentic_checkpoints WHERE thread_id = ?", (run_id,)).fetchone()
            found = int(row[0])
            if found:
                saver = SqliteSaver(conn)
                saver.get(run_id)  # the newest checkpoint rebuilt from its chain, as the resumed graph will
        finally:
            conn.close()
    except InputError:
        raise
    except sqlite3.Error as exc:
        return _not_ours(path, str(exc))
    except Exception as exc:  # the serializer's or the chain's own errors: the file is ours, its contents are not
        return _not_ours(path, f"its newest checkpoint cannot be read: {type(exc).__name__}: {exc}")
    return found


def _not_ours(path: Path, why: str) -> int:
    raise InputError(f"{path}: not a checkpoint database ({why}): the run cannot be resumed from it")


def _mission_begun(records: Sequence[Mapping[str, Any]]) -> bool:
    """Whether the trace shows a step of the mission begun (a step's event, or a call made by a step)."""
    return any(r.get("kind") == "step" or (r.get("kind") == "tool" and r.get("key")) for r in records)


__all__ = ["CHECKPOINTS_FILE", "LOCK_FILE", "Resumption", "RunHold", "open_resume", "resume_point"]
