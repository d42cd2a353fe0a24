"""The tools a run registers itself, beside the built-ins and ``--tools``: the ``flight.*`` tools on the agent's
vehicle link, ``perception.analyze_scene`` (the reasoner's look) and, in a swarm, ``swarm.*``. Their names are
reserved, so a plugin cannot shadow them (:func:`tools.loading.build_registry`'s ``reserved``), and ``validate``
puts stand-ins of them in its catalogue, so a mission's ``scopes:`` and ``call_tool`` steps are checked against
what the run will have.

>>> from tools import ToolRegistry
>>> registry = ToolRegistry()
>>> register_stand_ins(registry)
>>> registry.get("flight.status").scopes, registry.get(ANALYZE_SCENE).scopes
(('flight:read',), ('perception:read',))
>>> "flight.fly_to" in reserved_names() and "swarm.next_task" in reserved_names()
True
"""

from __future__ import annotations

from typing import Any

from flight.tools import flight_tools
from flight.vehicle import VehicleClient
from tools import ToolError, ToolRegistry
from tools.function import spec_from_function

from ..swarm.fleet_tools import register_swarm_tools

ANALYZE_SCENE = "perception.analyze_scene"
ANALYZE_SCENE_SCOPES = ("perception:read",)
"""The scopes the run's ``perception.analyze_scene`` asks of its caller."""


async def _no_vehicle() -> VehicleClient:
    raise ToolError("no vehicle: this catalogue only checks missions (agentic-uav validate)")


def _analyze_scene(focus: str | None = None, min_confidence: float = 0.5) -> dict[str, Any]:
    """Assess the scene (or one object of the world model) with the configured reasoner.

    Args:
        focus: an object id of the world model, or a description of what to look at
        min_confidence: fail when the assessment's confidence is below this, also after looking again
    """
    raise ToolError("no reasoner: this catalogue only checks missions (agentic-uav validate)")


def register_stand_ins(registry: ToolRegistry, *, swarm: bool = False) -> None:
    """Register tools named, scoped and shaped as the run's own, which fail if called: what a check needs."""
    for spec in flight_tools(_no_vehicle):
        registry.register(spec)
    registry.register(spec_from_function(_analyze_scene, name=ANALYZE_SCENE, scopes=list(ANALYZE_SCENE_SCOPES)))
    if swarm:
        register_swarm_tools(registry, None, "validate")


def reserved_names() -> frozenset[str]:
    """The names of every tool a run or a swarm run registers itself."""
    registry = ToolRegistry()
    register_stand_ins(registry, swarm=True)
    return frozenset(registry.names())


__all__ = ["ANALYZE_SCENE", "ANALYZE_SCENE_SCOPES", "register_stand_ins", "reserved_names"]
