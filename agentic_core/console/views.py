"""What the page draws besides the vehicle, as plain JSON: the scene's zones and landmarks in latitude and
longitude (the offline basemap, and the bounds of its rendered ground picture), the mission's legs, its geofence
and ceiling; and a World Model cut to what the map shows (each object's class, confidence, position and
covariance; the relations).

>>> from flight.sim.scene_file import load_scene
>>> view = scene_view(load_scene("scenes/hajj_emergency.yaml"))
>>> sorted(view), view["zones"][0]["kind"]
(['ground', 'home', 'landmarks', 'zones'], 'walkway')
"""

from __future__ import annotations

from typing import Any

from flight.sim.scene_model import Scene

from ..contracts.geodesy import offset_position
from ..contracts.policy_graph import Circle, PolicyGraph
from ..mission.validate import iter_steps
from .basemap import ground_bounds


def scene_view(scene: Scene) -> dict[str, Any]:
    """The scene as the map draws it: home, crowd zones (polygons, circles as 64-gons), landmarks."""
    home = scene.home

    def ll(north: float, east: float) -> list[float]:
        lat, lon = offset_position(home.lat_deg, home.lon_deg, north, east)
        return [round(lat, 7), round(lon, 7)]

    zones = [
        {"id": z.id, "kind": z.kind, "name": z.name, "density": z.density,
         "polygon": [ll(float(n), float(e)) for n, e in z.vertices()]}
        for z in scene.zones
    ]  # fmt: skip
    landmarks: list[dict[str, Any]] = []
    for mark in scene.landmarks:
        item: dict[str, Any] = {"id": mark.id, "kind": mark.kind, "name": mark.name}
        item["at"] = ll(mark.center.north, mark.center.east)
        if mark.polygon:
            item["polygon"] = [ll(p.north, p.east) for p in mark.polygon]
        landmarks.append(item)
    ground = {"bounds": ground_bounds(scene)}  # the picture itself: GET /api/runs/{run_id}/ground.png
    return {"home": [home.lat_deg, home.lon_deg], "zones": zones, "landmarks": landmarks, "ground": ground}


def mission_view(plan: PolicyGraph, home: tuple[float, float] | None) -> dict[str, Any]:
    """The mission as the map draws it: its legs (every written position, in order, trigger plans apart), the
    geofence (a circle or a polygon) and the ceiling."""
    legs: list[dict[str, Any]] = []
    for site in iter_steps(plan):
        args = site.step.model_dump(mode="json").get("args") or {}
        at = _position(args, home)
        if at is not None:
            legs.append(
                {
                    "step": site.step.id,
                    "action": site.step.action,
                    "at": at,
                    "trigger": site.scope.startswith("trigger:"),
                }
            )
    fence = plan.limits.geofence
    geofence: dict[str, Any] | None = None
    if isinstance(fence, Circle) and _numbers(fence.center.lat, fence.center.lon):
        geofence = {"center": [fence.center.lat, fence.center.lon], "radius_m": fence.radius_m}
    elif isinstance(fence, list) and all(_numbers(p.lat, p.lon) for p in fence):
        geofence = {"polygon": [[p.lat, p.lon] for p in fence]}
    return {"plan_id": plan.plan_id, "goal": plan.goal, "legs": legs, "geofence": geofence,
            "ceiling_m": plan.limits.max_altitude_m, "min_battery_pct": plan.limits.min_battery_pct}  # fmt: skip


def world_view(world: dict[str, Any]) -> dict[str, Any]:
    """A World Model (as JSON) cut to what the map shows."""
    objects = [
        {"id": o.get("id"), "class": o.get("class"), "conf": o.get("conf"), "state": o.get("state"),
         "lat": (o.get("pose") or {}).get("lat"), "lon": (o.get("pose") or {}).get("lon"), "cov": o.get("cov"),
         "stationary_s": o.get("stationary_s")}
        for o in world.get("objects") or []
    ]  # fmt: skip
    relations = [
        {"subj": r.get("subj"), "pred": r.get("pred"), "obj": r.get("obj")}
        for r in world.get("relations") or []
        if r.get("pred") in ("isolated_from", "near")
    ]
    return {"t": world.get("timestamp"), "objects": objects, "relations": relations}


def _numbers(*values: Any) -> bool:
    return all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)


def _position(args: dict[str, Any], home: tuple[float, float] | None) -> list[float] | None:
    if _numbers(args.get("lat"), args.get("lon")):
        return [float(args["lat"]), float(args["lon"])]
    north, east = args.get("north_m", args.get("north")), args.get("east_m", args.get("east"))
    if home is not None and isinstance(north, (int, float)) and isinstance(east, (int, float)):
        lat, lon = offset_position(home[0], home[1], float(north), float(east))
        return [lat, lon]
    return None


__all__ = ["mission_view", "scene_view", "world_view"]
