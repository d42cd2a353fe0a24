"""A run's seat in a swarm: what :class:`~agentic_core.run.runner.MissionRun` takes from the swarm it flies in
instead of making its own — the pace all the swarm's agents share (one clock), its vehicle on the swarm's lockstep
clock, and the swarm's tools (``swarm.*``) in its registry before its mission is loaded. A run alone has none.
"""

from __future__ import annotations

from typing import Any, Protocol

from tools import ToolRegistry

from ..agent.pacing import Pace
from .backends import Backend


class FleetSeat(Protocol):
    """One UAV's place in a swarm run (:mod:`agentic_core.run.swarm_run`)."""

    pace: Pace

    def backend(self, run: Any) -> Backend:
        """The vehicle of this UAV for ``run`` (a :class:`~agentic_core.run.runner.MissionRun`)."""

    def tools(self, registry: ToolRegistry, run: Any) -> None:
        """Register the swarm's tools for this UAV."""


__all__ = ["FleetSeat"]
