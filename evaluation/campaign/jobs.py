"""A campaign's unit of work: one scene through the systems still missing for it, named by content.

A record's *job id* is a SHA-256 of what decides it — the scene's digest, the system (its kind and model), the
campaign seed, the episode settings and the project's version — so a retried or resumed campaign skips exactly the
records it has, whatever order or machine produced them. Jobs run in an order shuffled by a seed the manifest
records (:func:`shuffled`), so slow scenes do not bunch up at one end and no system's timings follow the scene
order; the results file is rewritten in the balanced order at the end.

>>> from evaluation.campaign.systems import SystemSpec
>>> a = job_id("ab" * 32, SystemSpec(name="rules", kind="rules"), 0, EpisodeSettings())
>>> a == job_id("ab" * 32, SystemSpec(name="rules", kind="rules"), 0, EpisodeSettings()), len(a)
(True, 64)
>>> a == job_id("ab" * 32, SystemSpec(name="rules", kind="rules"), 1, EpisodeSettings())
False
>>> shuffled(["a", "b", "c", "d"], seed=3) == shuffled(["a", "b", "c", "d"], seed=3)
True
"""

from __future__ import annotations

import hashlib
import json
import random
from collections.abc import Sequence
from typing import TypeVar

from pydantic import BaseModel, ConfigDict, Field

import agentic_core
from flight.sim.scene_model import Scene

from .episode import EpisodeSettings, run_episode
from .model_calls import ModelSettings, ModelUsage, ResponseEntry, model_session
from .records import DecisionRecord
from .systems import SystemSpec

T = TypeVar("T")


def job_id(scene_sha256: str, system: SystemSpec, seed: int, settings: EpisodeSettings) -> str:
    """The content address of one (scene, system) record (see the module docs)."""
    text = json.dumps(
        {
            "scene": scene_sha256,
            "system": system.model_dump(mode="json"),
            "seed": seed,
            "settings": settings.model_dump(mode="json"),
            "version": agentic_core.__version__,
        },
        sort_keys=True,
        separators=(",", ":"),
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def shuffled(items: Sequence[T], seed: int) -> list[T]:
    """``items`` in an order drawn from ``seed`` alone (the same on every machine and Python version)."""
    out = list(items)
    random.Random(seed).shuffle(out)
    return out


class SceneJob(BaseModel):
    """One unit of work for a worker: a scene and the systems still to assess it (plain, picklable data)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scene: Scene
    systems: list[SystemSpec]
    settings: EpisodeSettings
    seed: int
    ids: dict[str, str] = Field(default_factory=dict, description="system name → job id of its record")
    models: ModelSettings = Field(default_factory=ModelSettings)
    replay: list[ResponseEntry] | None = Field(
        default=None, description="the cached model responses of this scene: answer from them, never a model"
    )


class JobOutput(BaseModel):
    """What a job gives back: its records, the model responses it received, and what its model calls cost."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    records: list[DecisionRecord]
    responses: list[ResponseEntry] = Field(default_factory=list)
    usage: list[ModelUsage] = Field(default_factory=list)


def run_job(job: SceneJob) -> JobOutput:
    """A worker's task: :func:`~evaluation.campaign.episode.run_episode` on the job's scene and systems, its
    model calls through the job's cache, limits and (for a replay) recorded responses."""
    with model_session(job.scene.id, job.models, job.replay) as session:
        records = run_episode(job.scene, job.systems, job.settings, job.seed, clients=session.client_for)
    stamped = [r.model_copy(update={"job_id": job.ids.get(r.system, "")}) for r in records]
    return JobOutput(records=stamped, responses=session.responses, usage=session.usage())


__all__ = ["JobOutput", "SceneJob", "job_id", "run_job", "shuffled"]
