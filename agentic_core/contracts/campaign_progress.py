"""``progress.json`` of a campaign directory: how far a campaign is (records done, failed and in all; the rate, each
system's, and the time left), rewritten by the campaign as it goes and read by the operator console, which may not
import ``evaluation``. A campaign that ended says so in ``state``; one killed stays ``running`` with an old
``updated_at`` (:func:`seems_stalled`).

>>> p = CampaignProgress(campaign="c10", total=20, done=5, failed=1, rate_per_s=0.5, eta_s=30.0, started_at=0.0,
...                      updated_at=10.0, systems={"yolo": SystemProgress(done=3, failed=1, rate_per_s=0.3)})
>>> p.share, seems_stalled(p, now=20.0), seems_stalled(p, now=1000.0)
(0.25, False, True)
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

PROGRESS_FILE = "progress.json"
STALLED_S = 120.0
"""A running campaign whose progress file is older than this seems stalled (killed, or its machine gone)."""


class SystemProgress(BaseModel):
    """One system's share of a campaign."""

    model_config = ConfigDict(extra="forbid")

    done: int = Field(default=0, ge=0, description="records of this system finished (failed ones included)")
    failed: int = Field(default=0, ge=0, description="of them, records with an error (no assessment)")
    rate_per_s: float = Field(default=0.0, ge=0.0, description="records of this system per second, this run")


class CampaignProgress(BaseModel):
    """A campaign's progress, as its ``progress.json`` holds it."""

    model_config = ConfigDict(extra="forbid")

    campaign: str = Field(description="the campaign directory's name")
    state: Literal["running", "ended"] = "running"
    total: int = Field(ge=0, description="records the campaign makes in all")
    done: int = Field(ge=0, description="records finished, those of earlier runs of it included")
    failed: int = Field(default=0, ge=0, description="of them, records with an error")
    rate_per_s: float = Field(default=0.0, ge=0.0, description="records per second, this run")
    eta_s: float | None = Field(default=None, ge=0.0, description="seconds left at this rate (None: unknown)")
    systems: dict[str, SystemProgress] = Field(default_factory=dict)
    last: str = Field(default="", description="the scene of the last record")
    started_at: float = Field(description="wall time this run started, Unix seconds")
    updated_at: float = Field(description="wall time of this state, Unix seconds")

    @property
    def share(self) -> float:
        """The finished share, 0 to 1."""
        return self.done / self.total if self.total else 1.0


def seems_stalled(progress: CampaignProgress, now: float) -> bool:
    """True for a campaign still ``running`` whose file was not rewritten for :data:`STALLED_S`."""
    return progress.state == "running" and now - progress.updated_at > STALLED_S


def campaign_progress_json_schema() -> dict[str, object]:
    """The JSON Schema of ``progress.json`` (``agentic-uav schema campaign-progress``)."""
    return CampaignProgress.model_json_schema()


__all__ = [
    "PROGRESS_FILE",
    "STALLED_S",
    "CampaignProgress",
    "SystemProgress",
    "campaign_progress_json_schema",
    "seems_stalled",
]
