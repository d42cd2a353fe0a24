"""A small swarm survey mission for the tests that fly vehicles of their own (``swarm run --connect``): no scene,
so its frame's origin is the simulator's default home; the area a box of north/east metres from it."""

from __future__ import annotations

from pathlib import Path

from agentic_core.contracts.geodesy import offset_position
from flight.sim.environment import Home

ORIGIN = Home()
"""The mission has no scene: its frame's origin is the simulator's default home."""


def _corner(north: float, east: float) -> str:
    lat, lon = offset_position(ORIGIN.lat_deg, ORIGIN.lon_deg, north, east)
    return f"{{lat: {lat:.7f}, lon: {lon:.7f}}}"


def survey_mission(
    path: Path,
    *,
    plan_id: str,
    goal: str,
    box_m: tuple[float, float, float, float],
    layers_m: tuple[float, float],
    layer_m: float,
    max_iterations: int,
    hover_s: float,
) -> Path:
    """Two UAVs survey the area ``box_m`` (south, north, west, east metres from the origin) sector by sector in
    their ``layers_m`` (``layer_m``: the parameter's default), holding ``hover_s`` while they wait, then fly home;
    written to ``path``."""
    south, north, west, east = box_m
    area = ", ".join(_corner(n, e) for n, e in ((south, west), (north, west), (north, east), (south, east)))
    path.write_text(
        f"""plan_id: {plan_id}
goal: {goal}
params:
  layer_m: {{type: number, default: {layer_m:g}}}
  uav: {{type: string, default: "uav-1"}}
  role: {{type: string, default: ""}}
swarm:
  vehicles: 2
  area: [{area}]
  layers_m: [{layers_m[0]:g}, {layers_m[1]:g}]
steps:
  - {{id: climb, action: takeoff, args: {{altitude_m: "${{params.layer_m}}"}}}}
  - id: work
    action: repeat
    depends_on: [climb]
    until: "next.skill == 'done'"
    max_iterations: {max_iterations}
    steps:
      - {{id: next, action: call_tool, tool: swarm.next_task}}
      - id: sweep
        action: branch
        if: "next.skill == 'survey_sector'"
        then:
          - id: survey
            action: survey
            args: {{polygon: "${{next.polygon}}", altitude_m: "${{params.layer_m}}", spacing_m: 30}}
          - {{id: surveyed, action: call_tool, tool: swarm.done, args: {{task: "${{next.id}}"}}}}
      - id: wait
        action: branch
        if: "next.skill == 'hold'"
        then:
          - {{id: idle, action: hover, args: {{duration_s: {hover_s:g}}}}}
  - {{id: go_home, action: rtl, depends_on: [work]}}
""",
        encoding="utf-8",
    )
    return path


__all__ = ["ORIGIN", "survey_mission"]
