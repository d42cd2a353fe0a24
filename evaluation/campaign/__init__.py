"""Evaluation campaigns: the same scenes through each system, one DecisionRecord per scene and system, the metrics.

Modules, one job each: :mod:`records` (the DecisionRecord and its JSONL/CSV files), :mod:`systems` (``--systems``
and building reasoners in a worker), :mod:`episode` (the observation protocol: one scene, its World Model, the
systems' assessments, the ground truth), :mod:`manifest` (what makes a campaign repeatable), :mod:`runner`
(balanced, parallel, resumable runs), :mod:`progress`, :mod:`metrics` (the paper's metrics and the ground-truth
ones) and :mod:`cli` (``agentic-uav eval campaign``).

>>> from pathlib import Path
>>> from evaluation.campaign import CampaignPlan, EpisodeSettings, parse_systems, run_campaign
>>> from flight.sim.scene_gen import generate_scenes
>>> plan = CampaignPlan(scenes=generate_scenes(4, seed=0), systems=parse_systems("yolo,rules"),
...                     settings=EpisodeSettings(frames=360), seed=0)
>>> result = run_campaign(plan, Path("runs/campaign-4"), workers=2)  # doctest: +SKIP
>>> print(result.metrics.to_markdown())  # doctest: +SKIP
"""

from .episode import EpisodeSettings, point_of_interest, run_episode
from .manifest import CampaignManifest, build_manifest, manifest_differences
from .metrics import CampaignMetrics, SystemMetrics, compute_metrics
from .records import DecisionRecord, read_records, write_csv, write_jsonl
from .runner import CampaignError, CampaignPlan, CampaignResult, run_campaign
from .systems import SystemSpec, SystemSpecError, parse_systems

__all__ = [
    "CampaignError",
    "CampaignManifest",
    "CampaignMetrics",
    "CampaignPlan",
    "CampaignResult",
    "DecisionRecord",
    "EpisodeSettings",
    "SystemMetrics",
    "SystemSpec",
    "SystemSpecError",
    "build_manifest",
    "compute_metrics",
    "manifest_differences",
    "parse_systems",
    "point_of_interest",
    "read_records",
    "run_campaign",
    "run_episode",
    "write_csv",
    "write_jsonl",
]
