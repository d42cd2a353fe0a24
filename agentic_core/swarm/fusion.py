"""The fleet's shared scene graph: every UAV's World Model merged into one view. Objects of one class that two
UAVs see at one place (within a chi-square gate on their combined covariance) are one object, its position fused by
covariance intersection — which stays consistent whatever the unknown correlation between the two estimates (both
UAVs may share a map error), where a naive Kalman product would claim more certainty than it has. An object one
UAV sees is never merged with another of its own objects. The view says which UAVs saw each object, so a casualty
one UAV reports can wait for ``k`` of the fleet to confirm it before the alert.

>>> import numpy as np
>>> sharp_north, sharp_east = np.diag([1.0, 9.0]), np.diag([9.0, 1.0])
>>> mean, cov, _ = covariance_intersection(np.array([0.0, 0.0]), sharp_north, np.array([1.0, 1.0]), sharp_east)
>>> np.round(mean, 2).tolist(), bool(np.trace(cov) < 10.0)  # each axis mostly from the view sharp on it
([0.1, 0.9], True)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment, minimize_scalar

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.world_model import WorldModel, WorldObject

GATE_CHI2 = 9.21
"""The association gate: chi-square with 2 degrees of freedom at 99 %."""


def covariance_intersection(
    a: np.ndarray, cov_a: np.ndarray, b: np.ndarray, cov_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Fuse two estimates of one quantity whose correlation is unknown: (mean, covariance, the weight of ``a``).

    The weight minimises the fused covariance's trace; the result is never less certain than it can prove."""
    inv_a, inv_b = np.linalg.inv(cov_a), np.linalg.inv(cov_b)

    def fused(w: float) -> np.ndarray:
        return np.asarray(np.linalg.inv(w * inv_a + (1.0 - w) * inv_b))

    best = minimize_scalar(lambda w: float(np.trace(fused(w))), bounds=(0.0, 1.0), method="bounded")
    w = float(best.x)
    cov = fused(w)
    mean = cov @ (w * inv_a @ a + (1.0 - w) * inv_b @ b)
    return mean, (cov + cov.T) / 2.0, w


@dataclass
class FleetView:
    """The merged World Model, and for each of its objects which UAV saw it under which of its own ids."""

    world: WorldModel
    sources: dict[str, dict[str, str]] = field(default_factory=dict)

    def seen_by(self, object_id: str) -> set[str]:
        """The UAVs that see the fleet object ``object_id``."""
        return set(self.sources.get(object_id, {}))

    def verified(self, object_id: str, k: int) -> bool:
        """Whether at least ``k`` UAVs see it (k-of-n confirmation before an alert)."""
        return len(self.seen_by(object_id)) >= k

    def fleet_id(self, uav: str, local_id: str) -> str | None:
        """The fleet object a UAV's own object became, or None."""
        return next((fid for fid, seen in self.sources.items() if seen.get(uav) == local_id), None)


def fuse(views: Mapping[str, WorldModel], *, gate_chi2: float = GATE_CHI2) -> FleetView:
    """Merge the World Models of the fleet (uav id → its latest World Model) into one :class:`FleetView`.

    UAVs are taken in the order of their ids; each one's objects are matched to the fleet's so far (one to one, by
    the smallest Mahalanobis distances within the gate) and fused, or added. A fleet object keeps the id
    ``<uav>/<its id>`` of its first UAV."""
    if not views:
        raise InputError("no World Model to fuse")
    fleet: list[WorldObject] = []
    sources: list[dict[str, str]] = []
    for uav in sorted(views):
        objects = views[uav].objects
        pairs = _associate(fleet, objects, gate_chi2)
        for i, j in pairs:
            fleet[i] = _merge(fleet[i], objects[j])
            sources[i][uav] = objects[j].id
        matched = {j for _, j in pairs}
        for j, obj in enumerate(objects):
            if j not in matched:
                fleet.append(obj.model_copy(update={"id": f"{uav}/{obj.id}"}))
                sources.append({uav: obj.id})
    first = views[sorted(views)[0]]
    latest = max(views.values(), key=lambda w: w.timestamp)
    world = first.model_copy(
        update={"timestamp": latest.timestamp, "objects": fleet, "relations": [], "ego_pose": latest.ego_pose}
    )
    return FleetView(world, {obj.id: seen for obj, seen in zip(fleet, sources, strict=True)})


def _position(obj: WorldObject) -> np.ndarray:
    return np.array([obj.pose.north, obj.pose.east])


def _associate(fleet: list[WorldObject], objects: list[WorldObject], gate_chi2: float) -> list[tuple[int, int]]:
    """One-to-one matches (fleet index, object index) of the same class within the gate, least distance overall."""
    if not fleet or not objects:
        return []
    big = 1e9
    cost = np.full((len(fleet), len(objects)), big)
    for i, f in enumerate(fleet):
        for j, o in enumerate(objects):
            if f.class_name != o.class_name:
                continue
            d = _position(f) - _position(o)
            d2 = float(d @ np.linalg.inv(np.array(f.cov) + np.array(o.cov)) @ d)
            if d2 <= gate_chi2:
                cost[i, j] = d2
    rows, cols = linear_sum_assignment(cost)
    return [(int(i), int(j)) for i, j in zip(rows, cols, strict=True) if cost[i, j] < big]


def _merge(a: WorldObject, b: WorldObject) -> WorldObject:
    """One object from two views of it: position by covariance intersection, the rest from the freshest view."""
    mean, cov, _ = covariance_intersection(_position(a), np.array(a.cov), _position(b), np.array(b.cov))
    fresh = b if b.last_seen > a.last_seen else a
    north, east = float(mean[0]), float(mean[1])
    lat, lon = _shifted(a, north, east)
    pose = fresh.pose.model_copy(update={"north": north, "east": east, "lat": lat, "lon": lon})
    cov_rows = ((float(cov[0, 0]), float(cov[0, 1])), (float(cov[1, 0]), float(cov[1, 1])))
    return fresh.model_copy(
        update={
            "id": a.id,
            "pose": pose,
            "cov": cov_rows,
            "conf": 1.0 - (1.0 - a.conf) * (1.0 - b.conf),
            "last_seen": max(a.last_seen, b.last_seen),
            "track_age_frames": max(a.track_age_frames, b.track_age_frames),
        }
    )


def _shifted(reference: WorldObject, north: float, east: float) -> tuple[float, float]:
    """Latitude and longitude of a local point, through home found from an object whose pose gives both frames."""
    home = offset_position(reference.pose.lat, reference.pose.lon, -reference.pose.north, -reference.pose.east)
    return offset_position(*home, north, east)


__all__ = ["GATE_CHI2", "FleetView", "covariance_intersection", "fuse"]
