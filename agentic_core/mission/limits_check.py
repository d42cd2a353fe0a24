"""The mission's limits checked on the file, before anything flies: every command a step will send, as far as it
is written out, goes through the flight :class:`~agentic_core.mission.envelope.Envelope` — the same geometry the
dispatcher checks each resolved command with — so a place is judged the same whether it is written as lat/lon or
as north/east metres from home, and whether ``validate`` or the flight finds it.

Positions in north/east metres need the home they are measured from: ``home`` (``validate --home``, a scene's home,
the simulator's default). Without one only lat/lon positions are placed. With it a take-off is checked too: the
aircraft takes off from home, which must lie inside the geofence. Values written as ``${...}`` and world-model
targets are known only in flight, where the envelope checks them.

>>> from agentic_core.mission.validate import load_mission
>>> text = '''plan_id: P
... goal: trap
... limits: {geofence: {center: {lat: 21.4133, lon: 39.8933}, radius_m: 200}, max_altitude_m: 25}
... steps: [{id: out, action: fly_to, args: {north_m: 215, east_m: 0, alt_m: 20}}]
... '''
>>> try:
...     load_mission(text, file="trap.yaml", home=(21.4133, 39.8933))
... except Exception as exc:
...     print(exc)
trap.yaml:4:51: fly_to: the destination is 15 m outside the geofence
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

from ..contracts.policy_graph import (
    ACTION_TOOLS,
    Circle,
    Limits,
    PolicyGraph,
    Step,
    SurveyStep,
    step_args,
)
from .envelope import Envelope
from .geometry import lawnmower

Path = tuple[str | int, ...]
LatLonPoint = tuple[float, float]
PLACED = ("flight.takeoff", "flight.fly_to", "flight.orbit", "flight.land")
"""The flight tools whose arguments name a place or a height."""


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _known_fence(limits: Limits) -> Limits:
    """``limits`` with a geofence written with ``${...}`` dropped: it is only known in flight."""
    fence = limits.geofence
    points = [fence.center] if isinstance(fence, Circle) else list(fence or [])
    if all(_number(p.lat) and _number(p.lon) for p in points):
        return limits
    return limits.model_copy(update={"geofence": None})


def _origin(limits: Limits) -> LatLonPoint | None:
    """Where to measure lat/lon positions from when home is not known: any point of the fence will do."""
    fence = limits.geofence
    if isinstance(fence, Circle):
        return float(fence.center.lat), float(fence.center.lon)
    if fence:
        return float(fence[0].lat), float(fence[0].lon)
    return None


class LimitsCheck:
    """The envelope over a mission's steps as written; ``home`` places north/east positions (None: skip them)."""

    def __init__(self, plan: PolicyGraph, home: LatLonPoint | None = None) -> None:
        self.limits = _known_fence(plan.limits)
        self.home = home
        origin = home or _origin(self.limits)
        self.envelope = Envelope(self.limits, home=lambda: origin)

    @property
    def active(self) -> bool:
        """Whether there is anything to check (a fence or a ceiling; the floor is checked with them)."""
        return self.limits.geofence is not None or self.limits.max_altitude_m is not None

    def step(self, step: Step, path: Path) -> Iterator[tuple[Path, str]]:
        """(document path, message) for each limit ``step`` (at ``path``) breaks as written."""
        args = step_args(step)
        tool = getattr(step, "tool", None) if step.action == "call_tool" else ACTION_TOOLS.get(step.action)
        if isinstance(step, SurveyStep):
            yield from self._survey(step, args, path)
        elif tool in PLACED:
            yield from self._command(step.action, str(tool), args, (*path, "args"))

    def _command(self, action: str, tool: str, args: Mapping[str, Any], where: Path) -> Iterator[tuple[Path, str]]:
        known = {k: v for k, v in args.items() if k != "target_id"}  # a world-model object: placed in flight only
        if self.home is None and ("north_m" in known or "east_m" in known):
            known = {k: v for k, v in known.items() if k not in ("north_m", "east_m")}
        for field, message in self.envelope.violations(tool, known):
            if field != "position":
                yield (*where, field), f"{action}: {message}"
            elif self.home is not None:  # the aircraft stands at home when the mission starts
                yield (*where[:-1], "action"), f"{action}: home is {message.removeprefix('the aircraft stands ')}"

    def _survey(self, step: SurveyStep, args: Mapping[str, Any], path: Path) -> Iterator[tuple[Path, str]]:
        where = (*path, "args")
        height = args.get("altitude_m")
        for _, message in self.envelope.violations("flight.fly_to", {"alt_m": height}):
            yield (*where, "altitude_m"), f"survey: {message.replace('alt_m', 'altitude_m', 1)}"
        polygon = args.get("polygon")
        if not isinstance(polygon, list) or not all(_number(p.get("lat")) and _number(p.get("lon")) for p in polygon):
            return
        corners = [(float(p["lat"]), float(p["lon"])) for p in polygon]
        outside = False
        for j, (lat, lon) in enumerate(corners):
            for _, message in self.envelope.violations("flight.fly_to", {"lat": lat, "lon": lon}):
                outside = True
                yield (*where, "polygon", j), f"survey: polygon point {j} {message.replace('the destination ', '')}"
        spacing = args.get("spacing_m")
        if outside or not isinstance(spacing, int | float):
            return
        for n, (lat, lon) in enumerate(lawnmower(corners, float(spacing))):
            for _, message in self.envelope.violations("flight.fly_to", {"lat": lat, "lon": lon}):
                yield (*where, "polygon"), f"survey: leg point {n} {message.replace('the destination ', '')}"
                return  # the first leg out says it; the rest follow from it


__all__ = ["LimitsCheck"]
