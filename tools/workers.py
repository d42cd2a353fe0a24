"""Threads that run synchronous tools, so a caller can stop waiting when a tool overruns its timeout.

Each calling thread gets a worker thread of its own and hands it work through a lock: no shared queue or pool
bookkeeping, which makes the hand-off several times cheaper than ``ThreadPoolExecutor.submit().result()`` (the
tool-call path is hot). A tool that overruns keeps its worker until it returns (Python cannot kill a thread); the
caller moves on with a fresh worker, and the old one ends when the tool returns. Idle workers end after a while.
"""

from __future__ import annotations

import contextvars
import queue
import threading
from collections.abc import Callable
from typing import Any, TypeVar

from .errors import CallTimeout

T = TypeVar("T")
IDLE_EXIT_S = 60.0


class _Job:
    __slots__ = ("context", "done", "error", "fn", "value")

    def __init__(self, fn: Callable[[], Any]) -> None:
        self.fn = fn
        self.context = contextvars.copy_context()
        self.done = threading.Lock()
        self.done.acquire()
        self.value: Any = None
        self.error: BaseException | None = None


class _Worker:
    def __init__(self, name: str) -> None:
        self.jobs: queue.SimpleQueue[_Job | None] = queue.SimpleQueue()
        self.abandoned = False
        self.lock = threading.Lock()  # "nothing queued, so end" and "not ended, so queue" must not interleave
        threading.Thread(target=self._loop, name=name, daemon=True).start()

    def _loop(self) -> None:
        while not self.abandoned:
            try:
                job = self.jobs.get(timeout=IDLE_EXIT_S)
            except queue.Empty:
                with self.lock:
                    if self.jobs.empty():
                        self.abandoned = True
                        return
                continue
            if job is None:
                return
            try:
                job.value = job.context.run(job.fn)
            except BaseException as exc:
                job.error = exc
            job.done.release()


class ThreadHandoff:
    """Runs a function on the calling thread's worker and waits at most ``timeout`` seconds for it."""

    def __init__(self, name: str = "tool-worker") -> None:
        self.name = name
        self._local = threading.local()
        self._workers: set[_Worker] = set()
        self._lock = threading.Lock()

    def run(self, fn: Callable[[], T], timeout: float | None) -> T:
        """``fn()``'s value, or its exception; :class:`CallTimeout` when it has not returned in ``timeout`` s."""
        job = _Job(fn)
        worker: _Worker | None = getattr(self._local, "worker", None)
        while True:
            if worker is None or worker.abandoned:
                worker = self._local.worker = _Worker(f"{self.name}-{threading.current_thread().name}")
                with self._lock:
                    self._workers = {w for w in self._workers if not w.abandoned} | {worker}
            with worker.lock:
                if not worker.abandoned:
                    worker.jobs.put(job)
                    break
            worker = None  # it ended on its idle timer just now
        if not job.done.acquire(timeout=-1 if timeout is None else max(timeout, 0.0)):
            worker.abandoned = True  # it ends when fn returns; this thread gets a new worker next time
            self._local.worker = None
            raise CallTimeout(f"no answer in {timeout:.3g} s")
        if job.error is not None:
            raise job.error
        return job.value  # type: ignore[no-any-return]

    def close(self) -> None:
        """Let idle workers end now."""
        with self._lock:
            workers, self._workers = self._workers, set()
        for worker in workers:
            worker.abandoned = True
            worker.jobs.put(None)
