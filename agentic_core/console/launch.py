"""Resuming and forking runs from the console: each flies in a child process, ``agentic-uav run --resume``, so it
writes its folder as any run does and the console follows it from its files. A fork is made first
(:func:`agentic_core.run.fork.fork_run`: a new run id from a checkpoint; the original is only read). The runs a
console started are stopped with it (SIGTERM: each ends ``interrupted``, resumable).

>>> import tempfile
>>> launcher = Launcher(Path(tempfile.mkdtemp()))
>>> launcher.running()
[]
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

from ..contracts.errors import InputError
from ..run.fork import fork_run
from .runs import run_folder

LOG_FILE = "console-launch.log"
"""The child's terminal output, in its run folder."""


class RunBusy(InputError):
    """The run is already flying, started by this console."""


class Launcher:
    """Starts and keeps the runs this console resumed or forked (one child process each)."""

    def __init__(self, runs_dir: Path, *, python: str = sys.executable) -> None:
        self.runs_dir = runs_dir
        self.python = python
        self._lock = threading.Lock()
        self._children: dict[str, subprocess.Popen[bytes]] = {}

    def resume(self, run_id: str) -> str:
        """Go on with ``run_id`` (what ``agentic-uav run --resume RUN_ID`` does); returns its id."""
        run_folder(self.runs_dir, run_id)
        self._start(run_id)
        return run_id

    def fork(self, run_id: str, checkpoint_id: str) -> str:
        """A new run from ``run_id``'s ``checkpoint_id``, flying; returns the new id."""
        run_folder(self.runs_dir, run_id)
        new_id = fork_run(self.runs_dir, run_id, checkpoint_id)
        self._start(new_id)
        return new_id

    def running(self) -> list[str]:
        """The ids of the runs this console started that still fly."""
        with self._lock:
            return sorted(rid for rid, child in self._children.items() if child.poll() is None)

    def stop(self, timeout_s: float = 20.0) -> None:
        """Ask every child still flying to stop (SIGTERM: the run ends ``interrupted``), and wait for each."""
        with self._lock:
            children = list(self._children.values())
        for child in children:
            if child.poll() is None:
                child.send_signal(signal.SIGTERM)
        for child in children:
            try:
                child.wait(timeout_s)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()

    def _start(self, run_id: str) -> None:
        with self._lock:
            child = self._children.get(run_id)
            if child is not None and child.poll() is None:
                raise RunBusy(f"run {run_id} is already flying (started by this console)")
            folder = self.runs_dir / run_id
            argv = [self.python, "-m", "agentic_core.cli", "run", "--resume", run_id,
                    "--runs-dir", str(self.runs_dir), "--quiet"]  # fmt: skip
            with (folder / LOG_FILE).open("ab") as log:
                self._children[run_id] = subprocess.Popen(
                    argv, stdin=subprocess.DEVNULL, stdout=log, stderr=subprocess.STDOUT, env=dict(os.environ)
                )


__all__ = ["LOG_FILE", "Launcher", "RunBusy"]
