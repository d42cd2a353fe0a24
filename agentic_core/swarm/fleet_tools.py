"""The swarm's tools in one UAV's registry: how its agent, running its own mission, takes part — asks for its next
task, says one is done, claims a casualty for the fleet, has it verified by another UAV, has a kit delivered.
Each is a call on the :class:`~agentic_core.swarm.coordinator.SwarmCoordinator` as this UAV, scope ``swarm:task``.

>>> from tools import ToolError, ToolRegistry
>>> from agentic_core.swarm.signing import SwarmKey
>>> from agentic_core.swarm.coordinator import SwarmCoordinator
>>> swarm = SwarmCoordinator(SwarmKey.generate("doc"), [], [])
>>> registry = ToolRegistry()
>>> register_swarm_tools(registry, swarm, "uav-1", wait=lambda: None)
>>> registry.names("swarm")
['swarm.claim', 'swarm.clearance', 'swarm.deliver', 'swarm.done', 'swarm.next_task', 'swarm.verify']
>>> sorted(registry.get("swarm.verify").scopes)
['swarm:task']
>>> swarm.close()
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from tools import ToolError, ToolRegistry
from tools.function import spec_from_function

from .coordinator import SwarmCoordinator

SCOPE = "swarm:task"


def register_swarm_tools(
    registry: ToolRegistry,
    coordinator: SwarmCoordinator | None,
    uav: str,
    *,
    wait: Callable[[], None] = lambda: None,
    separation_m: float = 15.0,
) -> None:
    """Register ``swarm.*`` for ``uav``; ``wait`` pauses between looks while it waits on the swarm; ``separation_m``
    is how far other UAVs must be before it descends through their layers. Without a coordinator (``agentic-uav
    validate``: the tools' names and arguments are all a check needs) every call fails: there is no swarm."""

    def swarm_() -> SwarmCoordinator:
        if coordinator is None:
            raise ToolError("no swarm: a swarm mission flies with agentic-uav swarm run")
        return coordinator

    def next_task() -> dict[str, Any]:
        """This UAV's next work: skill (survey_sector, verify_casualty, deliver_kit, hold or done), id, where, alt_m."""
        return swarm_().next_task(uav)

    def done(task: str) -> dict[str, Any]:
        """Report a piece of a task done (a survey of the sector, a verification, a delivery).

        Args:
            task: the task's id, as next_task gave it
        """
        return swarm_().task_done(uav, task)

    def claim(object_id: str) -> dict[str, Any]:
        """Respond to a casualty for the fleet: claimed, unless another UAV already responds to it.

        Args:
            object_id: the casualty's id in this UAV's World Model
        """
        return swarm_().claim(uav, object_id)

    def verify(casualty: str, timeout_s: float = 120.0) -> dict[str, Any]:
        """Have another UAV look at a claimed casualty; verified when the mission's k UAVs see it.

        Args:
            casualty: the casualty's id, as claim gave it
            timeout_s: simulated seconds to wait for the verification
        """
        return swarm_().verify(uav, casualty, timeout_s, wait)

    def clearance(task: str, timeout_s: float = 120.0) -> dict[str, Any]:
        """Wait until no other UAV is in the air near the task's place, before descending there through the layers.

        Args:
            task: the task's id, as next_task gave it
            timeout_s: simulated seconds to wait at most
        """
        return swarm_().clearance(uav, task, separation_m, timeout_s, wait)

    def deliver(casualty: str) -> dict[str, Any]:
        """Award the delivery of a medkit to the casualty by Contract Net (the nearest UAV carrying one wins).

        Args:
            casualty: the casualty's id, as claim gave it
        """
        return swarm_().deliver(uav, casualty)

    calls = ((next_task, 30.0), (done, 30.0), (claim, 30.0), (verify, 600.0), (clearance, 600.0), (deliver, 60.0))
    for fn, timeout in calls:
        registry.register(spec_from_function(fn, name=f"swarm.{fn.__name__}", scopes=[SCOPE], timeout_s=timeout))


__all__ = ["SCOPE", "register_swarm_tools"]
