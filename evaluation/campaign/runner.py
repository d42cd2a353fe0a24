"""Running a campaign: every scene through every system, balanced, in parallel, resumable, recorded.

The unit of work is a scene: one job observes it once and lets every system still missing for it assess the same
World Model (:func:`~evaluation.campaign.episode.run_episode`), so scenes × systems are interleaved and, after
each job, every system has as many records as the others. Jobs run in the calling process (``workers=1``) or in a
:class:`~concurrent.futures.ProcessPoolExecutor`; workers get plain data (scene, system specs, settings) and build
their reasoners themselves.

Files in the campaign directory:

* ``manifest.json`` — what the campaign is (:mod:`evaluation.campaign.manifest`); written first;
* ``results.jsonl`` — each finished record appended (flushed and fsynced) as soon as its job ends; on a restart
  the (scene, system) pairs already there are skipped, a torn last line is cut, and a different manifest is
  refused; when the campaign completes the file is rewritten in the balanced order (scene by scene, systems in
  the order given), so an interrupted and resumed campaign ends with the same file as an uninterrupted one,
  timings aside;
* ``results.csv`` (flat columns), ``metrics.md`` and ``metrics.json`` — written when the campaign completes.

>>> import tempfile
>>> from flight.sim.scene_gen import generate_scene
>>> from evaluation.campaign.episode import EpisodeSettings
>>> from evaluation.campaign.systems import parse_systems
>>> plan = CampaignPlan(scenes=[generate_scene(1, persons=30)], systems=parse_systems("yolo,rules"),
...                     settings=EpisodeSettings(frames=30))
>>> with tempfile.TemporaryDirectory() as out:
...     result = run_campaign(plan, Path(out), quiet=True)
...     print([(r.scene_id, r.system) for r in result.records])
...     print(sorted(p.name for p in Path(out).iterdir()))
[('gen-1', 'yolo'), ('gen-1', 'rules')]
['manifest.json', 'metrics.json', 'metrics.md', 'results.csv', 'results.jsonl']
"""

from __future__ import annotations

import contextlib
import functools
import multiprocessing
import os
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from pydantic import BaseModel, ConfigDict, Field, model_validator

from agentic_core.contracts.errors import AgenticUAVError
from flight.sim.scene_model import Scene

from .episode import EpisodeSettings, run_episode
from .manifest import CampaignManifest, SceneSource, build_manifest, load_manifest, manifest_differences
from .metrics import CampaignMetrics, compute_metrics, write_metrics
from .progress import Progress
from .records import DecisionRecord, RecordFileError, append_record, read_records, write_csv, write_jsonl
from .systems import SystemSpec

MANIFEST = "manifest.json"
RESULTS_JSONL = "results.jsonl"
RESULTS_CSV = "results.csv"


class CampaignError(AgenticUAVError):
    """A campaign that cannot start or go on; ``usage`` errors (exit 2) are the caller's to fix."""

    def __init__(self, message: str, *, usage: bool = True) -> None:
        super().__init__(message)
        self.usage = usage
        self.exit_status = 2 if usage else 1


class CampaignPlan(BaseModel):
    """What to run: scenes, systems, episode settings, the campaign seed and where the scenes came from."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scenes: list[Scene] = Field(min_length=1)
    systems: list[SystemSpec] = Field(min_length=1)
    settings: EpisodeSettings = Field(default_factory=EpisodeSettings)
    seed: int = Field(default=0, ge=0)
    scene_source: SceneSource | None = None

    @model_validator(mode="after")
    def _unique(self) -> CampaignPlan:
        for label, names in (("scene id", [s.id for s in self.scenes]), ("system", [s.name for s in self.systems])):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"each {label} must be unique; repeated: {', '.join(dup)}")
        return self

    def source(self) -> SceneSource:
        return self.scene_source or SceneSource(kind="files", count=len(self.scenes))


class SceneJob(BaseModel):
    """One unit of work for a worker: a scene and the systems still to assess it (plain, picklable data)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scene: Scene
    systems: list[SystemSpec]
    settings: EpisodeSettings
    seed: int


def run_job(job: SceneJob) -> list[DecisionRecord]:
    """A worker's task: :func:`~evaluation.campaign.episode.run_episode` on the job's scene and systems."""
    return run_episode(job.scene, job.systems, job.settings, job.seed)


@dataclass
class CampaignResult:
    """A finished campaign: its records in balanced order, what ran now, and the files written."""

    out_dir: Path
    manifest: CampaignManifest
    records: list[DecisionRecord]
    metrics: CampaignMetrics
    ran: int = 0
    resumed_from: int = 0
    files: dict[str, Path] = field(default_factory=dict)


def run_campaign(
    plan: CampaignPlan,
    out_dir: Path,
    *,
    workers: int = 1,
    quiet: bool = False,
    stream: TextIO | None = None,
) -> CampaignResult:
    """Run (or resume) ``plan`` in ``out_dir`` with ``workers`` processes; see the module docs.

    Raises :class:`CampaignError`: a directory holding a different campaign, another run in progress on it, a
    results file that cannot be read (usage errors), or a job that failed (a bug: ``usage=False``).
    """
    if workers < 1:
        raise CampaignError(f"--workers must be at least 1, got {workers}")
    manifest = build_manifest(
        seed=plan.seed,
        scenes=plan.scenes,
        systems=plan.systems,
        settings=plan.settings,
        scene_source=plan.source(),
        workers=workers,
    )
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CampaignError(f"{out_dir}: cannot create the campaign directory ({exc.strerror or exc})") from None
    with _locked(out_dir):
        done = _prepare(out_dir, manifest)
        keys = {(s.id, system.name) for s in plan.scenes for system in plan.systems}
        finished = {r.key for r in done if r.key in keys}
        total = len(keys)
        progress = Progress(total, len(finished), stream=stream, quiet=quiet)
        if finished:
            progress.note(f"resuming in {out_dir}: {len(finished)} of {total} records already done")
        jobs = [
            SceneJob(
                scene=scene,
                systems=[s for s in plan.systems if (scene.id, s.name) not in finished],
                settings=plan.settings,
                seed=plan.seed,
            )
            for scene in plan.scenes
        ]
        jobs = [job for job in jobs if job.systems]
        ran = 0
        try:
            for records in _execute(jobs, workers, progress):
                for record in records:
                    append_record(out_dir / RESULTS_JSONL, record)
                ran += len(records)
                progress.advance(len(records), records[0].scene_id if records else "")
        finally:
            progress.finish()
        return _finish(out_dir, plan, manifest, ran, len(finished))


def _execute(jobs: list[SceneJob], workers: int, progress: Progress) -> Iterator[list[DecisionRecord]]:
    if not jobs:
        return
    if workers == 1 or len(jobs) == 1:
        for job in jobs:
            yield _checked(job, functools.partial(run_job, job))
        return
    count = min(workers, len(jobs))
    progress.note(f"{len(jobs)} scenes on {count} worker processes")
    executor = ProcessPoolExecutor(max_workers=count, mp_context=_context())
    futures: dict[Future[list[DecisionRecord]], SceneJob] = {}
    try:
        futures = {executor.submit(run_job, job): job for job in jobs}
        for future in as_completed(futures):
            yield _checked(futures[future], future.result)
    except BaseException:
        executor.shutdown(wait=False, cancel_futures=True)
        raise
    executor.shutdown(wait=True)


def _checked(job: SceneJob, result: Callable[[], list[DecisionRecord]]) -> list[DecisionRecord]:
    try:
        records = result()
    except BrokenProcessPool as exc:
        raise CampaignError(f"a worker process died ({exc}); resume with the same command", usage=False) from exc
    except Exception as exc:
        raise CampaignError(f"scene {job.scene.id}: {type(exc).__name__}: {exc}", usage=False) from exc
    return records


def _context() -> multiprocessing.context.BaseContext:
    """``forkserver`` where there is one (POSIX): workers start clean, never a copy of a threaded parent, and fork
    from a server that has imported the episode code once."""
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([__name__])
    return context


@contextlib.contextmanager
def _locked(out_dir: Path) -> Iterator[None]:
    """One campaign run per directory at a time: an advisory lock on the directory itself, released when the run
    (or its process) ends."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: no lock
        yield
        return
    fd = os.open(out_dir, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise CampaignError(f"{out_dir}: another campaign is running in this directory") from None
        yield
    finally:
        os.close(fd)


def _prepare(out_dir: Path, manifest: CampaignManifest) -> list[DecisionRecord]:
    """Check (or write) the manifest and read the records already there."""
    manifest_path, results = out_dir / MANIFEST, out_dir / RESULTS_JSONL
    if manifest_path.exists():
        try:
            stored = load_manifest(manifest_path)
        except ValueError as exc:
            raise CampaignError(str(exc)) from None
        differences = manifest_differences(stored, manifest)
        if differences:
            raise CampaignError(
                f"{out_dir} holds a different campaign; it is resumed only with the same settings. Differences: "
                + "; ".join(differences)
                + ". Use another --out directory, or repeat the original command."
            )
    elif results.exists() and results.stat().st_size:
        raise CampaignError(f"{out_dir}: {RESULTS_JSONL} exists without a {MANIFEST}; not a campaign directory")
    else:
        _write_text(manifest_path, manifest.model_dump_json(indent=2) + "\n")
    try:
        return read_records(results, repair=True)
    except RecordFileError as exc:
        raise CampaignError(str(exc)) from None


def _finish(
    out_dir: Path, plan: CampaignPlan, manifest: CampaignManifest, ran: int, resumed_from: int
) -> CampaignResult:
    """Rewrite the results in balanced order, write the CSV and the metrics."""
    found: dict[tuple[str, str], DecisionRecord] = {}
    for record in read_records(out_dir / RESULTS_JSONL):
        found.setdefault(record.key, record)
    ordered = [found[(s.id, system.name)] for s in plan.scenes for system in plan.systems]
    write_jsonl(out_dir / RESULTS_JSONL, ordered)
    write_csv(out_dir / RESULTS_CSV, ordered)
    metrics = compute_metrics(ordered, [s.name for s in plan.systems])
    md, js = write_metrics(out_dir, metrics)
    files = {
        "manifest": out_dir / MANIFEST,
        "results_jsonl": out_dir / RESULTS_JSONL,
        "results_csv": out_dir / RESULTS_CSV,
        "metrics_md": md,
        "metrics_json": js,
    }
    return CampaignResult(out_dir, manifest, ordered, metrics, ran, resumed_from, files)


def _write_text(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


__all__ = [
    "CampaignError",
    "CampaignPlan",
    "CampaignResult",
    "SceneJob",
    "run_campaign",
    "run_job",
]
