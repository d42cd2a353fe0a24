"""Where a campaign's jobs run, named by ``--executor``: this machine's processes, or a Dask cluster.

* ``local:K`` — K worker processes here (``--workers K`` is the same); ``local:1`` runs every job in the calling
  process;
* ``dask-local:K`` — a Dask ``LocalCluster`` of K single-threaded worker processes bound to 127.0.0.1, started
  for the campaign and stopped after it (no dashboard);
* ``dask://HOST:PORT`` — an existing Dask scheduler (``dask scheduler`` and ``dask worker`` on any machines that
  can import this package and reach HOST).

Each gives a standard :class:`concurrent.futures.Executor` (Dask's ``Client.get_executor()``); no scheduling of our
own. Dask is the optional extra ``distributed``, imported only when a Dask executor is chosen.

>>> parse_executor("local:2")
ExecutorSpec(kind='local', workers=2, address=None)
>>> parse_executor("dask://127.0.0.1:8786").text
'dask://127.0.0.1:8786'
>>> parse_executor("ray:4")
Traceback (most recent call last):
...
evaluation.campaign.executors.ExecutorSpecError: --executor: 'ray:4' is not an executor; expected local:K, \
dask-local:K or dask://HOST:PORT
"""

from __future__ import annotations

import contextlib
import multiprocessing
import re
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any, Literal, NamedTuple, TypeVar

from pydantic import BaseModel, ConfigDict

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.extras import require

T = TypeVar("T")
ExecutorKind = Literal["local", "dask-local", "dask"]
USAGE = "local:K, dask-local:K or dask://HOST:PORT"
MAX_WORKERS = 1024
CONNECT_TIMEOUT_S = 10.0
"""How long to try to reach a ``dask://`` scheduler before saying none answers."""
_COUNT = re.compile(r"^(local|dask-local):(\d{1,6})$")
_ADDRESS = re.compile(r"^dask://(\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9.-]{1,253}):(\d{1,5})$")


class ExecutorSpecError(InputError):
    """An ``--executor`` value that names no executor, or a Dask scheduler that cannot be reached."""


class ExecutorSpec(BaseModel):
    """An executor as named on the command line (recorded in the manifest, never compared)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    kind: ExecutorKind
    workers: int | None = None
    address: str | None = None

    @property
    def text(self) -> str:
        return f"dask://{self.address}" if self.kind == "dask" else f"{self.kind}:{self.workers}"


def parse_executor(text: str) -> ExecutorSpec:
    """The executor ``text`` names (see the module docs); :class:`ExecutorSpecError` saying what is accepted."""
    value = text.strip()
    counted = _COUNT.match(value)
    if counted:
        workers = int(counted.group(2))
        if not 1 <= workers <= MAX_WORKERS:
            raise ExecutorSpecError(f"--executor: {text!r}: K must be 1 to {MAX_WORKERS}")
        kind: ExecutorKind = "local" if counted.group(1) == "local" else "dask-local"
        return ExecutorSpec(kind=kind, workers=workers)
    address = _ADDRESS.match(value)
    if address:
        port = int(address.group(2))
        if not 1 <= port <= 65535:
            raise ExecutorSpecError(f"--executor: {text!r}: the port must be 1 to 65535")
        return ExecutorSpec(kind="dask", address=f"{address.group(1)}:{port}")
    raise ExecutorSpecError(f"--executor: {text!r} is not an executor; expected {USAGE}")


class Pool(NamedTuple):
    """An open executor and how many jobs to keep in flight on it (its workers; twice that on Dask, whose
    workers then never wait for the next job)."""

    executor: Executor
    slots: int


class InlineExecutor(Executor):
    """Runs each job as it is submitted, in the calling thread (``local:1``): no process, nothing to pickle."""

    def submit(self, fn: Callable[..., T], /, *args: Any, **kwargs: Any) -> Future[T]:
        future: Future[T] = Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # the caller reads it from the future, as from any executor
            future.set_exception(exc)
        return future


@contextlib.contextmanager
def open_executor(spec: ExecutorSpec, *, jobs: int, preload: str | None = None) -> Iterator[Pool]:
    """The executor ``spec`` names, for ``jobs`` jobs (never more local workers than jobs), shut down on exit.

    ``preload`` is a module the worker processes (local and dask-local) import once, before their first job.
    """
    if spec.kind == "local":
        count = min(spec.workers or 1, max(jobs, 1))
        if count == 1:
            yield Pool(InlineExecutor(), 1)
            return
        with _shut(ProcessPoolExecutor(max_workers=count, mp_context=_context(preload))) as pool:
            yield Pool(pool, count)
        return
    distributed = require("distributed", "distributed")
    if spec.kind == "dask-local":
        import dask

        # No dashboard, so no use for the workers' statistical profiler, which samples every thread's stack each
        # 10 ms: a cost on every episode. The workers import the episode code as they start, as local ones do.
        with dask.config.set({"distributed.worker.profile.enabled": False}):
            cluster = distributed.LocalCluster(
                n_workers=spec.workers or 1,
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
                silence_logs=40,  # errors only: the campaign's own progress line is the display
                preload=[preload] if preload else [],
            )
        with cluster, distributed.Client(cluster) as client, _shut(client.get_executor(pure=False)) as executor:
            yield Pool(executor, 2 * (spec.workers or 1))
        return
    try:
        client = distributed.Client(f"tcp://{spec.address}", timeout=f"{CONNECT_TIMEOUT_S}s")
    except (OSError, TimeoutError) as exc:
        raise ExecutorSpecError(
            f"--executor {spec.text}: no Dask scheduler answers at {spec.address} ({exc})"
        ) from None
    with client, _shut(client.get_executor(pure=False)) as executor:
        threads = sum(int(n) for n in client.nthreads().values())
        yield Pool(executor, 2 * max(threads, 1))


@contextlib.contextmanager
def _shut(executor: Executor) -> Iterator[Executor]:
    """Wait for the jobs on a normal exit; on an error or an interrupt, give up the jobs not yet finished."""
    try:
        yield executor
    except BaseException:
        executor.shutdown(wait=False)
        raise
    executor.shutdown(wait=True)


def _context(preload: str | None) -> multiprocessing.context.BaseContext:
    """``forkserver`` where there is one (POSIX): workers start clean, never a copy of a threaded parent, and fork
    from a server that has imported the episode code once."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    if preload:
        context.set_forkserver_preload([preload])
    return context


__all__ = ["ExecutorSpec", "ExecutorSpecError", "InlineExecutor", "Pool", "open_executor", "parse_executor"]
