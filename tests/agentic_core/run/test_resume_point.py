"""Resume's guards, each attacked: a second process on a run's folder is refused at once, and a holder killed with
``kill -9`` blocks nobody; a checkpoint database that is random bytes, truncated, empty, someone else's, or a
folder is named and refused before anything flies; a run killed before its first checkpoint starts again."""

from __future__ import annotations

import operator
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
from pathlib import Path
from typing import Annotated, Any, TypedDict

import pytest

from agentic_core.contracts import InputError
from agentic_core.graph import END, START, StateGraph
from agentic_core.graph.checkpoint.sqlite import SqliteSaver
from agentic_core.run.resume_point import CHECKPOINTS_FILE, RunHold, open_resume, resume_point

REPO = Path(__file__).resolve().parents[3]
BEGUN = [{"kind": "run", "event": "start"}, {"kind": "step", "step": "climb", "status": "scheduled"}]
HOLDER = """
import sys
from pathlib import Path
from agentic_core.run.resume_point import RunHold
hold = RunHold.take(Path(sys.argv[1]), "r1", "resumed")
print("held", flush=True)
sys.stdin.read()
"""


def holder(folder: Path) -> subprocess.Popen[str]:
    """Another process holding ``folder``, as a resume in flight does, until its stdin closes or it is killed."""
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(folder)], cwd=REPO, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(REPO)})  # fmt: skip
    assert proc.stdout is not None and proc.stdout.readline().strip() == "held"
    return proc


def test_a_second_process_is_refused_at_once_and_a_killed_holder_blocks_nobody(tmp_path: Path) -> None:
    with holder(tmp_path) as proc:  # its pipes closed on the way out
        try:
            with pytest.raises(InputError) as refused:
                RunHold.take(tmp_path, "r1", "resumed")
            assert f"run r1 is already being resumed by pid {proc.pid}" in str(refused.value)
            with pytest.raises(InputError, match="already being resumed"):
                open_resume(tmp_path, "r1")
            proc.send_signal(signal.SIGKILL)  # the kernel lets go of the lock: no stale lock file blocks the next
            proc.wait(timeout=30.0)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(timeout=30.0)
    hold = RunHold.take(tmp_path, "r1", "resumed")
    assert (tmp_path / "run.lock").read_text().split() == [str(os.getpid()), "resumed"]
    hold.release()
    hold.release()  # twice is harmless
    RunHold.take(tmp_path, "r1", "flown").release()


def test_in_one_process_the_folder_is_held_until_released(tmp_path: Path) -> None:
    hold = RunHold.take(tmp_path, "r1", "flown")
    with pytest.raises(InputError, match=f"already being flown by pid {os.getpid()}"):
        RunHold.take(tmp_path, "r1", "resumed")
    hold.release()
    RunHold.take(tmp_path, "r1", "resumed").release()


class Tally(TypedDict):
    log: Annotated[list[str], operator.add]


def checkpointed(folder: Path, run_id: str = "r1", rows: int = 1, kill: bool = False) -> Path:
    """A checkpoint database as a run leaves it: a graph of ``rows`` steps checkpointed under ``run_id``; with
    ``kill``, this process is then killed, the database still open."""
    path = folder / CHECKPOINTS_FILE
    with SqliteSaver.from_conn_string(str(path)) as saver:
        if rows:
            graph = StateGraph(Tally)
            graph.add_node("step", lambda s: {"log": [os.urandom(16).hex()]})
            graph.add_conditional_edges("step", lambda s: END if len(s["log"]) >= rows else "step")
            graph.add_edge(START, "step")
            config = {"configurable": {"thread_id": run_id}, "recursion_limit": rows + 10}
            graph.compile(checkpointer=saver).invoke({"log": []}, config)
        if kill:
            os.kill(os.getpid(), signal.SIGKILL)
    return path


def test_a_checkpoint_whose_contents_cannot_be_read_is_refused(tmp_path: Path) -> None:
    path = checkpointed(tmp_path, rows=3)
    with sqlite3.connect(path) as conn:
        conn.execute("UPDATE agentic_checkpoints SET body = ? WHERE seq = (SELECT MAX(seq) FROM agentic_checkpoints)",
                     (b"\x00not a checkpoint",))  # fmt: skip
    conn.close()
    with pytest.raises(InputError, match="newest checkpoint cannot be read"):
        resume_point(tmp_path, "r1", BEGUN)


def test_a_run_with_a_checkpoint_goes_on_from_it(tmp_path: Path) -> None:
    checkpointed(tmp_path)
    assert resume_point(tmp_path, "r1", BEGUN) is True
    resumption = open_resume(tmp_path, "r1")
    assert resumption.from_start is False and resumption.snapshot is None
    RunHold.drop(resumption.hold)


KILLED = """
import os, sys
from pathlib import Path
from tests.agentic_core.run.test_resume_point import checkpointed
checkpointed(Path(sys.argv[1]), rows=int(sys.argv[2]), kill=True)
"""


def killed_mid_run(folder: Path) -> Path:
    """A checkpoint database left by ``kill -9``: its pages in the WAL beside it, never copied into the file."""
    proc = subprocess.run([sys.executable, "-c", KILLED, str(folder), "40"], cwd=REPO, timeout=120.0,
                          env={**os.environ, "PYTHONPATH": str(REPO)})  # fmt: skip
    assert proc.returncode == -signal.SIGKILL
    path = folder / CHECKPOINTS_FILE
    assert Path(f"{path}-wal").stat().st_size > path.stat().st_size
    sound = folder / "sound"
    shutil.copytree(folder, sound)
    assert resume_point(sound, "r1", BEGUN) is True  # before the damage: a sound database
    return path


def random_bytes(path: Path) -> None:
    path.write_bytes(os.urandom(64 * 1024))


def cut_to_8k(path: Path) -> None:
    with path.open("r+b") as f:
        f.truncate(8192)


def someone_elses(path: Path) -> None:
    path.unlink()
    with sqlite3.connect(path) as conn:
        conn.execute("CREATE TABLE photos (id INTEGER)")
    conn.close()


def a_folder(path: Path) -> None:
    path.unlink()
    path.mkdir()


def random_bytes_beside_its_wal(path: Path) -> None:
    """Bytes SQLite reads past when every page it needs is in the WAL (these did, where urandom's often do not)."""
    path.write_bytes(bytes((i * 7919) % 251 for i in range(64 * 1024)))


@pytest.mark.parametrize("damage", [random_bytes, cut_to_8k, someone_elses, a_folder, random_bytes_beside_its_wal])
def test_a_damaged_checkpoint_database_is_named_and_refused_and_the_folder_let_go(tmp_path: Path, damage: Any) -> None:
    # killed, every page still in the WAL and the file itself destroyed; or a database well over 8 KiB, as a run's is
    path = killed_mid_run(tmp_path) if damage is random_bytes_beside_its_wal else checkpointed(tmp_path, rows=300)
    damage(path)
    with pytest.raises(InputError) as refused:
        open_resume(tmp_path, "r1")
    assert str(path) in str(refused.value) and "resume" in str(refused.value)
    RunHold.take(tmp_path, "r1", "resumed").release()  # the refused resume let go of the folder


def test_a_run_killed_before_its_first_checkpoint_starts_again_but_one_that_lost_them_is_refused(
    tmp_path: Path,
) -> None:
    assert resume_point(tmp_path, "r1", [{"kind": "run", "event": "start"}]) is False  # no database yet
    checkpointed(tmp_path, rows=0)  # the database made, killed before the first checkpoint
    assert resume_point(tmp_path, "r1", [{"kind": "run", "event": "start"}]) is False
    checkpointed(tmp_path / "other", run_id="another-run")
    assert resume_point(tmp_path / "other", "r1", [{"kind": "run"}]) is False
    for records in (BEGUN, [{"kind": "tool", "name": "flight.takeoff", "key": "r1:climb:1.1"}]):
        with pytest.raises(InputError, match="holds no checkpoint of run r1"):
            resume_point(tmp_path, "r1", records)
    (tmp_path / CHECKPOINTS_FILE).write_bytes(b"")  # emptied: nothing to go on from, but the trace says it began
    with pytest.raises(InputError, match=str(tmp_path / CHECKPOINTS_FILE)):
        resume_point(tmp_path, "r1", BEGUN)
    assert resume_point(tmp_path, "r1", []) is False
