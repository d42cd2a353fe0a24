"""What the memory layer hands a reasoner: a :class:`Recollection` (one remembered thing near here, with where it
came from), through the :class:`RecallPort` context port. Plain data, so reasoners need not import the store.

>>> r = Recollection(key="R1:8", kind="incident", text="west gate: 104 persons", lat=21.413, lon=39.889,
...                  distance_m=12.0, provenance=Provenance(run_id="R1", seq=8, step="patrol/log_west#1", sim_t=103.8))
>>> r.cite()
'[memory incident/R1:8]'
"""

from __future__ import annotations

from typing import Literal, Protocol

from pydantic import BaseModel, ConfigDict, Field

from .world_model import WorldModel

MemoryKind = Literal["incident", "casualty", "alert", "decision", "approval", "knowledge"]
MEMORY_KINDS: tuple[MemoryKind, ...] = ("incident", "casualty", "alert", "decision", "approval", "knowledge")


class Provenance(BaseModel):
    """Where a memory came from: the run, its trace line, the mission step, the vehicle's clock; or a document."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    run_id: str | None = None
    seq: int | None = Field(default=None, description="the trace line (RunEvent.seq) it was recorded from")
    step: str | None = Field(default=None, description="the mission step, as in the idempotency key")
    sim_t: float | None = Field(default=None, description="the vehicle's clock, seconds")
    mission: str | None = None
    scene: str | None = None
    verdict: str | None = Field(default=None, description="the operator's answer, for an approval")
    source: str | None = Field(default=None, description="a knowledge document's file")
    version: str | None = None
    valid_until: str | None = None


class Recollection(BaseModel):
    """One memory as a reasoner receives it."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    key: str
    kind: MemoryKind
    text: str
    severity: str | None = None
    lat: float | None = None
    lon: float | None = None
    distance_m: float | None = Field(default=None, description="from where the aircraft is now")
    provenance: Provenance = Field(default_factory=Provenance)

    def cite(self) -> str:
        """How an assessment's rationale names it (``agentic-uav memory why`` takes the part after ``memory``)."""
        return f"[memory {self.kind}/{self.key}]"


class RecallPort(Protocol):
    """The context port: the memories relevant to a World Model (about one object, if ``focus`` names it)."""

    def __call__(self, world: WorldModel, focus: str | None, /) -> list[Recollection]: ...


__all__ = ["MEMORY_KINDS", "MemoryKind", "Provenance", "RecallPort", "Recollection"]
