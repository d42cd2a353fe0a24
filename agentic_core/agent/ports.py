"""The agent's ports: what the agent loop needs from the rest of a run, as Protocols. The run (the composition
root, :mod:`agentic_core.run`) plugs in the concrete parts — a simulated or a MAVLink-connected vehicle, the
perception loop over a scene, a reasoner — and the agent never reaches past these.
"""

from __future__ import annotations

from typing import Any, Protocol

from ..perception.world_model import WorldModel
from ..reasoning.assessment import Decision


class WorldSource(Protocol):
    """The World Model as perception keeps it up to date."""

    @property
    def world(self) -> WorldModel: ...

    def target(self, object_id: str) -> tuple[float, float] | None:
        """Where an object of the World Model is (latitude, longitude), or None when it is not known."""
        ...

    def resolve(self, object_id: str) -> str | None:
        """The id the object has in the World Model now (a dropped track re-identified), or None."""
        ...


class VehicleView(Protocol):
    """What the agent reads of the vehicle: its clock and its latest telemetry, as the link reports them."""

    def clock(self) -> float:
        """The vehicle's clock, seconds (simulated seconds in a simulation)."""
        ...

    def view(self) -> dict[str, Any]:
        """The latest telemetry as a flat mapping (what mission expressions read as ``vehicle``)."""
        ...


class ReasonerPort(Protocol):
    """Tier 2: assesses the scene, or one object of it."""

    @property
    def name(self) -> str: ...

    def assess(self, world: WorldModel, focus: str | None = None) -> Decision: ...


class Publish(Protocol):
    """Publishes one event on the run's bus (:meth:`agentic_core.agent.bus.EventBus.publish`)."""

    def __call__(self, kind: str, /, **fields: Any) -> Any: ...


__all__ = ["Publish", "ReasonerPort", "VehicleView", "WorldSource"]
