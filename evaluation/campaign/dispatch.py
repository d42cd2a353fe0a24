"""Handing a campaign's jobs to an executor a few at a time, and their outputs back as each finishes.

At most the pool's ``slots`` jobs are in flight; before each submission ``more()`` is asked, so a spent budget
starts no new job while the running ones finish and are kept. A job that raises is a :class:`CampaignError`
naming its scene (a bug, exit 1); on any error or interrupt the jobs not yet finished are given up.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Generator
from concurrent.futures import FIRST_COMPLETED, Future, wait
from concurrent.futures.process import BrokenProcessPool

from .errors import CampaignError
from .executors import ExecutorSpec, open_executor
from .jobs import JobOutput, SceneJob, run_job


def dispatch(
    jobs: list[SceneJob], spec: ExecutorSpec, *, more: Callable[[], bool] = lambda: True
) -> Generator[JobOutput, None, None]:
    """Run ``jobs`` on the executor ``spec`` names; yield each job's output as it finishes."""
    if not jobs:
        return
    with open_executor(spec, jobs=len(jobs), preload="evaluation.campaign.jobs") as pool:
        pending = deque(jobs)
        running: dict[Future[JobOutput], SceneJob] = {}
        try:
            while pending or running:
                while pending and len(running) < pool.slots and more():
                    job = pending.popleft()
                    running[pool.executor.submit(run_job, job)] = job
                if not running:
                    return
                done, _ = wait(list(running), return_when=FIRST_COMPLETED)
                for future in [f for f in running if f in done]:
                    yield _checked(running.pop(future), future)
        except BaseException:
            for future in running:
                future.cancel()
            raise


def _checked(job: SceneJob, future: Future[JobOutput]) -> JobOutput:
    try:
        return future.result()
    except BrokenProcessPool as exc:
        raise CampaignError(f"a worker process died ({exc}); resume with the same command", usage=False) from exc
    except Exception as exc:
        raise CampaignError(f"scene {job.scene.id}: {type(exc).__name__}: {exc}", usage=False) from exc


__all__ = ["dispatch"]
