"""The swarm's contracts: what UAVs tell each other over A2A. A :class:`SwarmMessage` is the signed envelope every
swarm message travels in (sender, nonce, timestamp, a kind and its body); :class:`UavState` is what an Agent Card
advertises of its aircraft; :class:`SwarmTask` and :class:`Bid` are what Contract Net allocates and offers.

Positions are local metres (north, east from the swarm's shared home; altitude above it), the frame every
vehicle's ``TelemetrySample`` and ``WorldModel`` already speak.

>>> message = SwarmMessage(kind="cfp", sender="ground", nonce="00" * 16, timestamp=1.5, body={"task": "T-1"})
>>> message.signed_text()
'{"body":{"task":"T-1"},"conversation":"","kind":"cfp","nonce":"00000000000000000000000000000000","recipient":null,"sender":"ground","timestamp":1.5}'
>>> UavState(uav_id="uav-1", position=Point(north=0, east=0, alt=30), battery_pct=80).has("medkit")
False
"""

from __future__ import annotations

import json
import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

Finite = Annotated[float, Field(allow_inf_nan=False)]
Name = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.:-]+$")]

MessageKind = Literal["cfp", "bid", "refuse", "award", "accept", "inform", "failure", "cancel", "state", "heartbeat"]
"""FIPA Contract Net's performatives as the swarm uses them, and ``state`` (a vehicle's news about itself)."""

Skill = Literal["survey_sector", "verify_casualty", "deliver_kit"]
"""What a UAV offers: survey a sector, verify a casualty another UAV found, deliver a kit it carries."""

SKILLS: tuple[Skill, ...] = ("survey_sector", "verify_casualty", "deliver_kit")


class SwarmContract(BaseModel):
    """Base of the swarm's records: unknown fields are errors."""

    model_config = ConfigDict(extra="forbid", frozen=True)


class Point(SwarmContract):
    """A place in the swarm's shared local frame, metres."""

    north: Finite
    east: Finite
    alt: Finite = Field(default=0.0, description="metres above home")

    def horizontal_to(self, other: Point) -> float:
        """Horizontal distance to ``other``, metres."""
        return math.hypot(self.north - other.north, self.east - other.east)

    def distance_to(self, other: Point) -> float:
        """Straight-line distance to ``other``, metres."""
        return math.hypot(self.horizontal_to(other), self.alt - other.alt)


class UavState(SwarmContract):
    """What a UAV's Agent Card advertises of its aircraft (the ``uav-state`` card extension's params)."""

    uav_id: Name
    position: Point
    battery_pct: Finite = Field(ge=0, le=100)
    payload: tuple[str, ...] = Field(default=(), description="what it carries: medkit, ...")
    status: Literal["idle", "busy", "failed"] = "idle"

    def has(self, item: str) -> bool:
        """Whether it carries ``item``."""
        return item in self.payload


class SwarmTask(SwarmContract):
    """A unit of work one UAV is awarded: a skill, where, and what it needs aboard."""

    id: Name
    skill: Skill
    where: Point
    needs: str | None = Field(default=None, description="a payload the task needs (deliver_kit: medkit)")
    work_s: Finite = Field(default=0.0, ge=0, description="seconds of work on site (a sector's survey)")


class Bid(SwarmContract):
    """A UAV's offer for a task: its cost (lower is better), from :mod:`agentic_core.swarm.cost`."""

    task_id: Name
    bidder: Name
    cost: Finite = Field(ge=0)


class SwarmMessage(SwarmContract):
    """The envelope of every swarm message: who sent it, to whom, when, a one-time nonce, and its HMAC signature.

    The signature covers :meth:`signed_text`, everything but itself, as canonical JSON."""

    kind: MessageKind
    sender: Name
    recipient: Name | None = Field(default=None, description="None: every member of the swarm")
    conversation: Annotated[str, Field(max_length=128)] = Field(default="", description="the Contract Net round")
    nonce: Annotated[str, Field(min_length=32, max_length=64, pattern=r"^[0-9a-f]+$")]
    timestamp: Finite = Field(description="sender's clock, Unix seconds")
    body: dict[str, Any] = Field(default_factory=dict)
    signature: Annotated[str, Field(max_length=128)] = Field(default="", description="hex HMAC-SHA256")

    @field_validator("body")
    @classmethod
    def _plain_json(cls, body: dict[str, Any]) -> dict[str, Any]:
        """Only what JSON carries unchanged: an infinity would be signed as null and arrive as something else."""
        json.dumps(body, allow_nan=False)
        return body

    def signed_text(self) -> str:
        """The canonical JSON the signature covers: every field but ``signature``, keys sorted, no spaces."""
        data = self.model_dump(mode="json", exclude={"signature"})
        return json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)


class Rejection(SwarmContract):
    """A swarm message refused on arrival, as the audit records it."""

    at: Finite = Field(description="receiver's clock, Unix seconds")
    receiver: str
    reason: Literal["forged", "replayed", "stale", "malformed", "unknown_sender", "misaddressed", "unauthorised"]
    detail: str = ""
    sender: str = Field(default="", description="the sender the message claimed (unverified)")
    kind: str = ""
    nonce: str = ""


__all__ = [
    "SKILLS",
    "Bid",
    "MessageKind",
    "Point",
    "Rejection",
    "Skill",
    "SwarmMessage",
    "SwarmTask",
    "UavState",
]
