"""Running a campaign: every scene through every system, balanced, in parallel, resumable, recorded.

The unit of work is a scene: one job observes it once and lets every system still missing for it assess the same
World Model (:func:`~evaluation.campaign.episode.run_episode`), so scenes × systems are interleaved and, after
each job, every system has as many records as the others. Jobs (:mod:`evaluation.campaign.jobs`: content-addressed,
in an order shuffled by the manifest's ``job_order_seed``) run on the executor ``--executor`` names
(:mod:`evaluation.campaign.executors`: this process, local processes, or Dask); workers get plain data (scene,
system specs, settings) and build their reasoners themselves.

Files in the campaign directory:

* ``manifest.json`` — what the campaign is (:mod:`evaluation.campaign.manifest`); written first;
* ``results.jsonl`` — each finished record appended (flushed and fsynced) as soon as its job ends; on a restart
  the records whose job id is already there are skipped, a torn last line is cut, and a different manifest is
  refused; when the campaign completes the file is rewritten in the balanced order (scene by scene, systems in
  the order given), so an interrupted and resumed campaign ends with the same file as an uninterrupted one,
  timings aside;
* ``model_cache.jsonl`` — every model answer, keyed by its request (:mod:`evaluation.campaign.model_calls`), so
  ``--replay`` can re-score the campaign with no model; only when a system calls a model;
* ``results.csv`` (flat columns), ``metrics.md`` and ``metrics.json`` — written when the campaign completes;
* ``progress.json`` — records done, failed and in all, rates and time left, rewritten as it goes (for the console).

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
['manifest.json', 'metrics.json', 'metrics.md', 'progress.json', 'results.csv', 'results.jsonl']
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from pydantic import BaseModel, ConfigDict, Field, model_validator

from agentic_core.contracts.campaign_progress import PROGRESS_FILE
from flight.sim.scene_model import Scene

from .budget import Budget, Spend
from .dispatch import dispatch
from .early_stop import StopRule
from .episode import EpisodeSettings, derive_seed
from .errors import BudgetSpent, CampaignError
from .executors import ExecutorSpec, parse_executor
from .jobs import JobOutput, SceneJob, job_id, run_job, shuffled
from .manifest import CampaignManifest, SceneSource, build_manifest, load_manifest, manifest_differences
from .metrics import CampaignMetrics, compute_metrics, write_metrics
from .model_calls import ModelSettings, ResponseEntry
from .progress import Progress
from .records import (
    TIMING_FIELDS,
    DecisionRecord,
    RecordFileError,
    append_record,
    read_records,
    write_csv,
    write_jsonl,
)
from .response_cache import append_responses, load_responses
from .systems import SystemSpec

MANIFEST = "manifest.json"
RESULTS_JSONL = "results.jsonl"
RESULTS_CSV = "results.csv"
MODEL_CACHE = "model_cache.jsonl"


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
    stopped_early: str | None = None
    """Why the campaign stopped adding scenes (``--stop-at-width``): the comparison that answered."""


def run_campaign(
    plan: CampaignPlan,
    out_dir: Path,
    *,
    workers: int = 1,
    executor: ExecutorSpec | str | None = None,
    quiet: bool = False,
    stream: TextIO | None = None,
    models: ModelSettings | None = None,
    budget: Budget | None = None,
    replay: Path | None = None,
    stop: StopRule | None = None,
) -> CampaignResult:
    """Run (or resume) ``plan`` in ``out_dir`` on ``executor`` (default ``local:workers``); see the module docs.

    ``models`` sets how model calls are made, ``budget`` when to stop, ``replay`` names a campaign directory
    whose ``model_cache.jsonl`` answers every model call instead of a model, and ``stop`` stops adding scenes
    once the primary comparison is known (:mod:`evaluation.campaign.early_stop`).

    Raises :class:`CampaignError`: a directory holding a different campaign, another run in progress on it, a
    results file that cannot be read (usage errors), or a job that failed (a bug: ``usage=False``);
    :class:`BudgetSpent` (exit 3) when the budget stopped it, what finished kept.
    """
    if workers < 1:
        raise CampaignError(f"--workers must be at least 1, got {workers}")
    spec = parse_executor(executor) if isinstance(executor, str) else executor or parse_executor(f"local:{workers}")
    order_seed = derive_seed(plan.seed, "job-order")
    manifest = build_manifest(
        seed=plan.seed,
        scenes=plan.scenes,
        systems=plan.systems,
        settings=plan.settings,
        scene_source=plan.source(),
        workers=spec.workers or 0,
    ).model_copy(update={"executor": spec.text, "job_order_seed": order_seed})
    cached = _replayed(replay) if replay is not None else None
    timings = _recorded_timings(replay) if replay is not None else {}
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CampaignError(f"{out_dir}: cannot create the campaign directory ({exc.strerror or exc})") from None
    with _locked(out_dir):
        done = _prepare(out_dir, manifest)
        digests = {entry.id: entry.sha256 for entry in manifest.scenes}
        ids = {
            scene.id: {s.name: job_id(digests[scene.id], s, plan.seed, plan.settings) for s in plan.systems}
            for scene in plan.scenes
        }
        expected = {i for per_scene in ids.values() for i in per_scene.values()}
        finished = {r.job_id for r in done} & expected
        total = len(expected)
        progress = Progress(total, len(finished), stream=stream, quiet=quiet, file=out_dir / PROGRESS_FILE)
        if finished:
            kept = [r for r in done if r.job_id in finished]
            progress.earlier([r.system for r in kept], [r.system for r in kept if r.error])
            progress.note(f"resuming in {out_dir}: {len(finished)} of {total} records already done")
        jobs = [
            SceneJob(
                scene=scene,
                systems=[s for s in plan.systems if ids[scene.id][s.name] not in finished],
                settings=plan.settings,
                seed=plan.seed,
                ids=ids[scene.id],
                models=models or ModelSettings(),
                replay=None if cached is None else cached.get(scene.id, []),
            )
            for scene in plan.scenes
        ]
        jobs = shuffled([job for job in jobs if job.systems], order_seed)
        if len(jobs) > 1 and spec.text != "local:1":
            progress.note(f"{len(jobs)} scenes on {spec.text}")
        limits = budget or Budget()
        spend = Spend()
        stopped: list[str] = []
        kept = [r for r in done if r.job_id in expected]
        answered: list[str] = []

        def more() -> bool:
            reason = spend.exceeded(limits) if limits.limited else None
            if reason and not stopped:
                stopped.append(reason)
            if stop is not None and not answered:
                check = stop.check_records(kept)
                if check.answered:
                    answered.append(check.text(stop))
                    progress.note(f"stopping early: {answered[0]}")
            return reason is None and not answered

        ran = 0
        try:
            with contextlib.closing(dispatch(jobs, spec, more=more)) as outputs:
                for output in outputs:
                    new = _keep(out_dir, output, progress, timings)
                    kept += new
                    ran += len(new)
                    spend.add(output.usage, limits)
        finally:
            progress.finish()
        if stopped or (limits.limited and not answered and ran < sum(len(j.systems) for j in jobs)):
            raise BudgetSpent(
                f"budget spent ({stopped[0] if stopped else spend.text()}): {ran} records run now, "
                f"{len(finished) + ran} of {total} kept in {out_dir}; run again with a larger budget to go on"
            )
        result = _finish(out_dir, plan, manifest, ran, len(finished), expected, partial=bool(answered))
        result.stopped_early = answered[0] if answered else None
        return result


def _keep(
    out_dir: Path, output: JobOutput, progress: Progress, timings: dict[str, dict[str, float | None]] | None = None
) -> list[DecisionRecord]:
    """Append a job's records and model responses to the campaign's files; the records kept. A replay's records
    carry the replayed campaign's ``timings`` (its model calls took that long; the replay asked none)."""
    kept = []
    for record in output.records:
        recorded = (timings or {}).get(record.job_id)
        kept.append(record.model_copy(update=recorded) if recorded else record)
        append_record(out_dir / RESULTS_JSONL, kept[-1])
    append_responses(out_dir / MODEL_CACHE, output.responses)
    label = output.records[0].scene_id if output.records else ""
    failed = [r.system for r in output.records if r.error]
    progress.advance(len(output.records), label, [r.system for r in output.records], failed)
    return kept


def _recorded_timings(directory: Path) -> dict[str, dict[str, float | None]]:
    """The timing fields of each record of the campaign in ``directory``, by job id (none when it has none)."""
    path = directory / RESULTS_JSONL
    if not path.is_file():
        return {}
    try:
        records = read_records(path)
    except RecordFileError as exc:
        raise CampaignError(f"--replay {directory}: {exc}") from None
    return {r.job_id: {name: getattr(r, name) for name in TIMING_FIELDS} for r in records if r.job_id}


def _replayed(directory: Path) -> dict[str, list[ResponseEntry]]:
    try:
        return load_responses(directory / MODEL_CACHE)
    except (OSError, ValueError) as exc:
        raise CampaignError(f"--replay {directory}: {exc}") from None


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
    out_dir: Path,
    plan: CampaignPlan,
    manifest: CampaignManifest,
    ran: int,
    resumed_from: int,
    expected: set[str],
    *,
    partial: bool = False,
) -> CampaignResult:
    """Rewrite the results in balanced order (only records of this campaign's jobs), write the CSV and metrics;
    ``partial`` (stopped early): of the scenes every system has finished."""
    found: dict[tuple[str, str], DecisionRecord] = {}
    for record in read_records(out_dir / RESULTS_JSONL):
        if record.job_id in expected:
            found.setdefault(record.key, record)
    scenes = [s for s in plan.scenes if not partial or all((s.id, x.name) in found for x in plan.systems)]
    ordered = [found[(s.id, system.name)] for s in scenes for system in plan.systems]
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
    "MODEL_CACHE",
    "BudgetSpent",
    "CampaignError",
    "CampaignPlan",
    "CampaignResult",
    "SceneJob",
    "run_campaign",
    "run_job",
]
