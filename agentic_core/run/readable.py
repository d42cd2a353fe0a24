"""Outputs a person can read: one id per object (the tracker's), linked to the scene's truth where a simulated
scene knows it ("P-1203 (scene P-12)"), and numbers rounded to what they mean (coordinates 1e-6°, metres 0.1).

>>> label("P-1203", {"P-1203": "P-12"}), label("P-7", {})
('P-1203 (scene P-12)', 'P-7')
>>> readable("rules on P-1203: critical at 21.41465442152097", {"P-1203": "P-12"})
'rules on P-1203 (scene P-12): critical at 21.414654'
>>> rounded({"lat_deg": 21.41465442152097, "alt_m": 15.871, "id": "P-1"})
{'lat_deg': 21.414654, 'alt_m': 15.9, 'id': 'P-1'}
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from flight.sim.scene_model import Scene

from ..contracts.geodesy import local_offset
from ..perception.world_model import WorldModel

LINK_RADIUS_M = 3.0
"""A track within this distance of a still scene actor of its class is that actor."""
STILL = frozenset({"collapsed", "sitting", "standing", "resting", "parked"})
LONG_FLOAT = re.compile(r"-?\d+\.\d{7,}")


def link_truth(world: WorldModel, scene: Scene) -> dict[str, str]:
    """Tracker id → the scene's actor id, for tracks lying on one of the scene's still, named actors."""
    home = scene.home
    links: dict[str, str] = {}
    for obj in world.objects:
        north, east = local_offset(home.lat_deg, home.lon_deg, obj.pose.lat, obj.pose.lon)
        best: tuple[float, str] | None = None
        for actor in scene.actors:
            if actor.behaviour not in STILL or actor.class_name != obj.class_name:
                continue
            gap = math.hypot(actor.position.north - north, actor.position.east - east)
            if gap <= LINK_RADIUS_M and (best is None or gap < best[0]):
                best = (gap, actor.id)
        if best is not None:
            links[obj.id] = best[1]
    return links


class TruthLinks(dict[str, str]):
    """The run's links from tracker ids to the scene's actors, each published once as it is found (``log``)."""

    def __init__(
        self, scene: Scene | None, publish: Callable[..., Any], earlier: Iterable[Mapping[str, Any]] = ()
    ) -> None:
        super().__init__()
        self.scene = scene
        self.publish = publish
        self.remember(earlier)

    def remember(self, records: Iterable[Mapping[str, Any]]) -> None:
        """Take back the links an earlier part of the run published (a resumed run's trace), without publishing
        them again, so its report still names the casualty by the track it had."""
        for record in records:
            track, truth = record.get("object"), record.get("truth")
            if record.get("kind") == "log" and isinstance(track, str) and isinstance(truth, str):
                self.setdefault(track, truth)

    def see(self, world: WorldModel) -> None:
        """Link the tracks of ``world`` (called with every decision's World Model, not every frame)."""
        if self.scene is None:
            return
        for track, truth in link_truth(world, self.scene).items():
            if track not in self:
                self[track] = truth
                self.publish(
                    "log", level="info", object=track, truth=truth, summary=f"tracked as {track} (scene {truth})"
                )


def label(object_id: str, links: Mapping[str, str]) -> str:
    """An object's id, with the scene's truth id when one is linked to it."""
    truth = links.get(object_id)
    return f"{object_id} (scene {truth})" if truth is not None and truth != object_id else object_id


def readable(text: str, links: Mapping[str, str]) -> str:
    """``text`` with every linked tracker id labelled and long floats cut to 6 decimals."""
    if links:  # one pass, so a label put in is never labelled again
        ids = "|".join(re.escape(i) for i in sorted(links, key=len, reverse=True))
        pattern = re.compile(rf"(?<![\w-])(?<!\(scene )({ids})(?![\w-])(?! \(scene)")
        text = pattern.sub(lambda m: label(m.group(1), links), text)
    return LONG_FLOAT.sub(lambda m: f"{float(m.group()):.6f}", text)


def rounded(data: Any) -> Any:
    """``data`` with coordinates (``lat``/``lon`` keys) to 1e-6° and other floats (metres, seconds) to 0.1."""
    if isinstance(data, dict):
        return {k: _round(k, v) if isinstance(v, float) else rounded(v) for k, v in data.items()}
    if isinstance(data, list):
        return [rounded(v) for v in data]
    return data


def _round(key: str, value: float) -> float:
    return round(value, 6) if key.split("_")[0] in ("lat", "lon") else round(value, 1)


__all__ = ["LINK_RADIUS_M", "TruthLinks", "label", "link_truth", "readable", "rounded"]
