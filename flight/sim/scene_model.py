"""What a simulated scene is made of: actors, crowd zones, landmarks and the ground truth, as pydantic models.

A :class:`Scene` is what a scene file holds (see ``scenes/*.yaml`` and :mod:`flight.sim.scene_file`): explicit actors
(a casualty, people sitting in shade, a parked ambulance), crowd zones that the simulation fills with walking
pilgrims at a density drawn from the scene's seed, named landmarks that relations can point at, and the ground
truth an evaluation scores against. Positions are north/east metres from the scene's home, the simulator's local
frame; the ground is the plane at the home's elevation.

Checks beyond the field types (ids unique and known, casualties collapsed and isolated, the ground truth's person
count) run when a scene is built and name the offending field, so a scene that loads is consistent.

>>> scene = Scene(
...     id="demo",
...     zones=[Zone(id="Z-1", kind="walkway", density=0.5, flow=Flow(heading_deg=0, speed_mps=1.2), polygon=[
...         NE(north=0, east=0), NE(north=100, east=0), NE(north=100, east=10), NE(north=0, east=10)])],
...     actors=[Actor(id="P-0", position=NE(north=50, east=-30), behaviour="collapsed")],
...     ground_truth=GroundTruth(expected_severity="critical", casualties=["P-0"], isolated=["P-0"]),
... )
>>> scene.persons, scene.zones[0].persons
(501, 500)
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import cached_property
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import BaseModel, ConfigDict, Field, ValidationInfo, model_validator

from agentic_core.contracts.faults import FaultText
from agentic_core.contracts.geodesy import offset_position
from agentic_core.contracts.polygon import Ring, distance_to_edge, points_in_circle, points_in_polygon, polygon_area
from flight.sim.environment import DEFAULT_HOME_ALT_MSL_M, DEFAULT_HOME_LAT_DEG, DEFAULT_HOME_LON_DEG, Home

FloatArray = NDArray[np.float64]
Path = tuple[str | int, ...]

Behaviour = Literal["walking", "running", "standing", "sitting", "resting", "collapsed", "driving", "parked"]
"""What an actor does. ``resting`` is lying down but alive (small movements); ``collapsed`` lies perfectly still."""
BEHAVIOURS: tuple[str, ...] = ("walking", "running", "standing", "sitting", "resting", "collapsed", "driving", "parked")
PERSON_BEHAVIOURS = frozenset(BEHAVIOURS[:6])
VEHICLE_BEHAVIOURS = frozenset({"driving", "parked"})
CROWD_BEHAVIOURS = frozenset({"walking", "running", "standing", "sitting", "resting"})
MOVING_BEHAVIOURS = frozenset({"walking", "running", "driving"})
Severity = Literal["none", "low", "high", "critical"]
ZoneKind = Literal["walkway", "plaza", "camp", "queue"]
LandmarkKind = Literal["exit", "gate", "tent", "medical_post", "road", "shade", "water", "camp", "other"]
ID_PATTERN = r"^[A-Za-z][A-Za-z0-9_.:-]{0,63}$"
DEFAULT_MIX: dict[Behaviour, float] = {"walking": 0.9, "standing": 0.1}
CROWDED_DENSITY = 2.0
"""Persons/m² from which a crowd is dense enough to log (ground-truth severity ``low`` without casualties)."""

_STRICT = ConfigDict(frozen=True, extra="forbid")


class NE(BaseModel):
    """A point (m) or a velocity (m/s) in the local frame: north and east of home."""

    model_config = _STRICT

    north: float
    east: float

    def array(self) -> FloatArray:
        return np.array([self.north, self.east], dtype=float)


class BodySize(BaseModel):
    """An actor's box: ``length_m`` along its heading, ``width_m`` across it, ``height_m`` above the ground."""

    model_config = _STRICT

    length_m: float = Field(gt=0.0, le=30.0)
    width_m: float = Field(gt=0.0, le=30.0)
    height_m: float = Field(gt=0.0, le=30.0)


UPRIGHT = BodySize(length_m=0.5, width_m=0.5, height_m=1.7)
SEATED = BodySize(length_m=0.7, width_m=0.6, height_m=1.0)
LYING = BodySize(length_m=1.8, width_m=0.6, height_m=0.3)
CAR = BodySize(length_m=4.5, width_m=1.8, height_m=1.5)


def default_size(class_name: str, behaviour: str) -> BodySize | None:
    """The body box of a class in a behaviour (a person lying is 1.8×0.6×0.3 m), ``None`` for unknown classes."""
    if class_name == "person":
        if behaviour in ("resting", "collapsed"):
            return LYING
        return SEATED if behaviour == "sitting" else UPRIGHT
    return CAR if class_name == "vehicle" else None


class Actor(BaseModel):
    """Someone or something in the scene. Moving actors face their velocity; others face ``heading_deg``.

    A walker in a ``zone`` follows that zone's flow (its own ``velocity`` only sets its speed); a walker without a
    zone keeps its ``velocity``, with a little jitter.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

    id: str = Field(pattern=ID_PATTERN, description='unique in the scene, e.g. "P-12" or "V-01"')
    class_name: str = Field(default="person", alias="class", pattern=r"^[a-z][a-z_]*$", description="person, vehicle…")
    position: NE
    velocity: NE = Field(default=NE(north=0.0, east=0.0), description="m/s")
    behaviour: Behaviour = "standing"
    heading_deg: float = Field(default=0.0, description="body orientation, 0 north, clockwise")
    size: BodySize | None = Field(default=None, description="default: by class and behaviour")
    zone: str | None = Field(default=None, description="the crowd zone a walker belongs to")

    def body_size(self) -> BodySize:
        size = self.size or default_size(self.class_name, self.behaviour)
        if size is None:  # scene checks refuse this; a bare Actor may still get here
            raise ValueError(f"actor {self.id}: class {self.class_name!r} has no default size; give size")
        return size


class Circle(BaseModel):
    model_config = _STRICT

    center: NE
    radius_m: float = Field(gt=0.0)


class Flow(BaseModel):
    """Where a zone's walkers go: towards ``heading_deg`` (0 north, clockwise) at ``speed_mps``; 0 m/s: milling."""

    model_config = _STRICT

    heading_deg: float = 0.0
    speed_mps: float = Field(default=0.0, ge=0.0, le=3.0)

    @property
    def direction(self) -> FloatArray:
        h = math.radians(self.heading_deg)
        return np.array([math.cos(h), math.sin(h)])


class Zone(BaseModel):
    """A crowd: an area (a polygon or a circle) filled at ``density`` persons/m² who behave by ``mix``.

    The simulation draws ``persons`` = round(density × area) pilgrims uniformly inside it from the scene's seed;
    ``mix`` gives the share of each behaviour (normalised). Walkers keep to the zone; in a flowing zone those who
    reach its downstream edge leave and a new pilgrim (a new id) enters upstream, so the density holds.
    """

    model_config = _STRICT

    id: str = Field(pattern=ID_PATTERN)
    kind: ZoneKind = "walkway"
    name: str = ""
    polygon: list[NE] | None = Field(default=None, min_length=3, description="corners in order around the area")
    circle: Circle | None = None
    density: float = Field(default=0.0, ge=0.0, le=8.0, description="persons per square metre")
    flow: Flow = Field(default_factory=Flow)
    mix: dict[Behaviour, float] = Field(
        default_factory=lambda: dict(DEFAULT_MIX), description="share of each behaviour"
    )

    @property
    def persons(self) -> int:
        return round(self.density * self.area()) if self.polygon or self.circle else 0

    def vertices(self) -> FloatArray:
        """The polygon's corners (K×2 north/east); a circle as a 64-gon."""
        if self.polygon is not None:
            return np.array([[p.north, p.east] for p in self.polygon], dtype=float)
        if self.circle is None:
            return np.zeros((0, 2))
        a = np.linspace(0.0, 2.0 * math.pi, 64, endpoint=False)
        c, r = self.circle.center, self.circle.radius_m
        return np.column_stack([c.north + r * np.cos(a), c.east + r * np.sin(a)])

    @cached_property
    def ring(self) -> Ring:
        """The polygon's edges worked out once (the crowd asks a zone about its walkers every step)."""
        return Ring(self.vertices())

    def area(self) -> float:
        if self.circle is not None and self.polygon is None:
            return math.pi * self.circle.radius_m**2
        return polygon_area(self.ring)

    def contains(self, points: FloatArray) -> NDArray[np.bool_]:
        """Which of N north/east points (N×2) lie inside (:mod:`agentic_core.contracts.polygon`: edges inside)."""
        if self.circle is not None and self.polygon is None:
            c = self.circle.center
            return points_in_circle(points, (c.north, c.east), self.circle.radius_m)
        return points_in_polygon(points, self.ring)

    def clearance(self, points: FloatArray) -> FloatArray:
        """Distance (m) from N points to the zone's boundary (its edges, or its circle): a point inside stays
        inside while it moves less than this."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if self.circle is not None and self.polygon is None:
            c = self.circle.center
            gap: FloatArray = np.abs(np.hypot(pts[:, 0] - c.north, pts[:, 1] - c.east) - self.circle.radius_m)
            return gap
        return distance_to_edge(pts, self.ring)

    def inside_and_clearance(self, points: FloatArray) -> tuple[NDArray[np.bool_], FloatArray]:
        """:meth:`contains` and :meth:`clearance` of the same points, in one pass."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if self.circle is not None and self.polygon is None:
            c = self.circle.center
            d = np.hypot(pts[:, 0] - c.north, pts[:, 1] - c.east)
            gap: FloatArray = np.abs(d - self.circle.radius_m)
            return d <= self.circle.radius_m, gap
        return self.ring.contains_and_distance(pts)

    def distance(self, points: FloatArray) -> FloatArray:
        """Ground distance (m) from N points to the zone: 0 inside."""
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        if self.circle is not None and self.polygon is None:
            c = self.circle.center
            d: FloatArray = np.maximum(np.hypot(pts[:, 0] - c.north, pts[:, 1] - c.east) - self.circle.radius_m, 0.0)
            return d
        return self.ring.outside_by(pts)

    def sample(self, n: int, rng: np.random.Generator) -> FloatArray:
        """``n`` points drawn uniformly inside the zone."""
        if self.circle is not None and self.polygon is None:
            c, r = self.circle.center, self.circle.radius_m
            rad = r * np.sqrt(rng.random(n))
            ang = rng.random(n) * 2.0 * math.pi
            return np.column_stack([c.north + rad * np.cos(ang), c.east + rad * np.sin(ang)])
        v = self.vertices()
        lo, hi = v.min(axis=0), v.max(axis=0)
        out = np.zeros((0, 2))
        while len(out) < n:  # rejection sampling; a polygon fills at least a sliver of its box
            batch = lo + (hi - lo) * rng.random((max(2 * (n - len(out)), 16), 2))
            out = np.vstack([out, batch[self.contains(batch)]])
        return out[:n]


class Landmark(BaseModel):
    """A named place relations can point at ("P-12 near Exit-3"): a point or an area."""

    model_config = _STRICT

    id: str = Field(pattern=ID_PATTERN, description='e.g. "Exit-3", "Med-1"')
    kind: LandmarkKind
    name: str = ""
    position: NE | None = None
    polygon: list[NE] | None = Field(default=None, min_length=3)

    @property
    def center(self) -> NE:
        if self.position is not None:
            return self.position
        pts = self.polygon or []
        return NE(north=sum(p.north for p in pts) / len(pts), east=sum(p.east for p in pts) / len(pts))


class GroundTruth(BaseModel):
    """What an evaluation scores against.

    ``casualties``: persons who need help (collapsed); ``isolated``: those of them more than ``isolation_m`` from
    anyone else and from every crowd zone (the paper's scenario 2); ``distractors``: people who look like they
    might need help but do not (sitting or resting in shade); ``persons``: how many persons the scene holds
    (explicit ones plus the zones' crowds), checked when given; ``expected_severity``: the assessment a correct
    reasoner gives — ``critical`` with an isolated casualty, ``high`` with casualties in the crowd only, ``low``
    for a dense crowd (>= 2 persons/m²) without casualties, ``none`` otherwise.
    """

    model_config = _STRICT

    expected_severity: Severity = "none"
    casualties: list[str] = Field(default_factory=list)
    isolated: list[str] = Field(default_factory=list)
    distractors: list[str] = Field(default_factory=list)
    persons: int | None = Field(default=None, ge=0)
    isolation_m: float = Field(default=15.0, gt=0.0)
    notes: str = ""


class HomePoint(BaseModel):
    """Where the scene's local frame starts: the simulator's home (near Mina by default)."""

    model_config = _STRICT

    lat_deg: float = Field(default=DEFAULT_HOME_LAT_DEG, gt=-90.0, lt=90.0)
    lon_deg: float = Field(default=DEFAULT_HOME_LON_DEG, ge=-180.0, le=180.0)
    alt_msl_m: float = Field(default=DEFAULT_HOME_ALT_MSL_M, ge=-500.0, le=9000.0)

    def to_home(self) -> Home:
        """The simulator's :class:`~flight.sim.environment.Home` at this point."""
        return Home(self.lat_deg, self.lon_deg, self.alt_msl_m)


class Scene(BaseModel):
    """A whole scene: explicit actors, crowd zones, landmarks, ground truth, and the seed its crowds come from."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    id: str = Field(pattern=ID_PATTERN)
    description: str = ""
    seed: int = Field(default=0, ge=0, description="draws the crowds and their motion")
    home: HomePoint = Field(default_factory=HomePoint)
    actors: list[Actor] = Field(default_factory=list)
    zones: list[Zone] = Field(default_factory=list)
    landmarks: list[Landmark] = Field(default_factory=list)
    ground_truth: GroundTruth = Field(default_factory=GroundTruth)
    faults: list[FaultText] = Field(
        default_factory=list, description="failures a run over this scene injects, e.g. battery=18%@S1, gps_loss@t=40s"
    )

    @model_validator(mode="after")
    def _consistent(self, info: ValidationInfo) -> Scene:
        if isinstance(info.context, dict) and info.context.get("defer_checks"):
            return self  # the file loader runs the checks itself, to place each problem at its line
        problems = scene_problems(self)
        if problems:
            raise ValueError("; ".join(f"{describe_path(path, self)}: {message}" for path, message in problems))
        return self

    @property
    def persons(self) -> int:
        """Persons in the scene: the explicit ones plus every zone's crowd."""
        return sum(a.class_name == "person" for a in self.actors) + sum(z.persons for z in self.zones)

    def actor(self, actor_id: str) -> Actor:
        return next(a for a in self.actors if a.id == actor_id)

    def geodetic(self, north_m: float, east_m: float) -> tuple[float, float]:
        """Latitude and longitude (degrees) of a point of the scene."""
        return offset_position(self.home.lat_deg, self.home.lon_deg, north_m, east_m)


def severity_rule(isolated: bool, casualties: bool, max_density: float) -> Severity:
    """The severity a correct assessment gives (see :class:`GroundTruth`)."""
    if isolated:
        return "critical"
    if casualties:
        return "high"
    return "low" if max_density >= CROWDED_DENSITY else "none"


def expected_severity(scene: Scene) -> Severity:
    """:func:`severity_rule` applied to a scene's ground-truth casualties and its zones' densities."""
    gt = scene.ground_truth
    return severity_rule(bool(gt.isolated), bool(gt.casualties), max((z.density for z in scene.zones), default=0.0))


def describe_path(path: Path, data: Any = None) -> str:
    """``actors[3] (P-S2).behaviour``: a field path as people read it, with the item's id when there is one."""
    out, node = "", data
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
            node = node[part] if isinstance(node, list) and 0 <= part < len(node) else None
            ident = node.get("id") if isinstance(node, dict) else getattr(node, "id", None)
            if isinstance(ident, str):
                out += f" ({ident})"
        else:
            out += f".{part}" if out else str(part)
            node = node.get(part) if isinstance(node, dict) else getattr(node, str(part), None)
    return out or "the scene"


def scene_problems(scene: Scene) -> list[tuple[Path, str]]:
    """Everything inconsistent in a scene beyond its field types, each with the path of the field at fault."""
    problems: list[tuple[Path, str]] = []
    seen: dict[str, str] = {}
    sections: list[tuple[str, Sequence[Actor | Zone | Landmark]]] = [
        ("actors", scene.actors),
        ("zones", scene.zones),
        ("landmarks", scene.landmarks),
    ]
    for section, items in sections:
        for i, item in enumerate(items):
            if item.id in seen:
                problems.append(((section, i, "id"), f"id {item.id!r} is already used by {seen[item.id]}"))
            seen.setdefault(item.id, f"{section}[{i}]")
    zones = {z.id: z for z in scene.zones}
    for i, z in enumerate(scene.zones):
        if (z.polygon is None) == (z.circle is None):
            problems.append((("zones", i), "a zone needs exactly one of polygon or circle"))
        elif z.area() <= 0.0:
            problems.append((("zones", i, "polygon"), "the polygon encloses no area"))
        if z.mix and sum(z.mix.values()) <= 0.0:
            problems.append((("zones", i, "mix"), "the behaviour shares must add up to more than 0"))
        for name, share in z.mix.items():
            if name not in CROWD_BEHAVIOURS:
                why = "casualties are explicit actors" if name == "collapsed" else "a crowd is made of persons"
                problems.append((("zones", i, "mix", name), f"{name!r} cannot be in a crowd mix ({why})"))
            elif share < 0.0:
                problems.append((("zones", i, "mix", name), "a share cannot be negative"))
        if not z.mix and z.density > 0:
            problems.append((("zones", i, "mix"), "a populated zone needs at least one behaviour"))
    for i, lm in enumerate(scene.landmarks):
        if (lm.position is None) == (lm.polygon is None):
            problems.append((("landmarks", i), "a landmark needs exactly one of position or polygon"))
    for i, a in enumerate(scene.actors):
        allowed = VEHICLE_BEHAVIOURS if a.class_name == "vehicle" else PERSON_BEHAVIOURS
        if a.class_name in ("person", "vehicle") and a.behaviour not in allowed:
            problems.append(
                (("actors", i, "behaviour"), f"a {a.class_name} can be {', '.join(sorted(allowed))}, not {a.behaviour}")
            )
        if a.size is None and default_size(a.class_name, a.behaviour) is None:
            problems.append((("actors", i, "class"), f"class {a.class_name!r} has no default size: give size"))
        if a.behaviour in MOVING_BEHAVIOURS and a.zone is None and a.velocity.north == a.velocity.east == 0.0:
            problems.append((("actors", i, "velocity"), f"a {a.behaviour} actor without a zone needs a velocity"))
        if a.zone is not None:
            zone = zones.get(a.zone)
            if zone is None:
                problems.append((("actors", i, "zone"), f"no zone {a.zone!r}; zones: {', '.join(zones) or 'none'}"))
            elif (zone.polygon is not None or zone.circle is not None) and not zone.contains(a.position.array())[0]:
                problems.append((("actors", i, "position"), f"outside its zone {a.zone!r}"))
    problems.extend(_ground_truth_problems(scene))
    return problems


def _ground_truth_problems(scene: Scene) -> list[tuple[Path, str]]:
    gt = scene.ground_truth
    problems: list[tuple[Path, str]] = []
    actors = {a.id: a for a in scene.actors}
    for field in ("casualties", "isolated", "distractors"):
        for j, ident in enumerate(getattr(gt, field)):
            if ident not in actors:
                problems.append((("ground_truth", field, j), f"no actor {ident!r}"))
    for j, ident in enumerate(gt.casualties):
        a = actors.get(ident)
        if a is not None and (a.class_name != "person" or a.behaviour != "collapsed"):
            problems.append((("ground_truth", "casualties", j), f"{ident} is not a collapsed person"))
    listed = set(gt.casualties)
    for i, a in enumerate(scene.actors):
        if a.behaviour == "collapsed" and a.id not in listed:
            problems.append((("actors", i, "behaviour"), f"{a.id} is collapsed but not in ground_truth.casualties"))
    populated = [z for z in scene.zones if z.density > 0 and (z.polygon is not None or z.circle is not None)]
    for j, ident in enumerate(gt.isolated):
        a = actors.get(ident)
        if a is None:
            continue
        if ident not in listed:
            problems.append((("ground_truth", "isolated", j), f"{ident} is not one of the casualties"))
        gap = _clearance(a, scene.actors, populated)
        if gap <= gt.isolation_m:
            problems.append(
                (
                    ("ground_truth", "isolated", j),
                    f"{ident} is {gap:.1f} m from others (isolation_m {gt.isolation_m:g})",
                )
            )
    for j, ident in enumerate(gt.distractors):
        if ident in listed:
            problems.append((("ground_truth", "distractors", j), f"{ident} is a casualty, not a distractor"))
    if gt.persons is not None and gt.persons != scene.persons:
        problems.append((("ground_truth", "persons"), f"the scene holds {scene.persons} persons, not {gt.persons}"))
    severity = gt.expected_severity
    if gt.casualties and severity in ("none", "low"):
        problems.append((("ground_truth", "expected_severity"), f"{severity!r} with casualties; high or critical"))
    if not gt.casualties and severity in ("high", "critical"):
        problems.append((("ground_truth", "expected_severity"), f"{severity!r} without casualties; none or low"))
    return problems


def _clearance(actor: Actor, actors: list[Actor], zones: list[Zone]) -> float:
    """Ground distance (m) from an actor to the nearest other actor or populated zone."""
    here = actor.position.array()
    gaps = [float(np.linalg.norm(other.position.array() - here)) for other in actors if other.id != actor.id]
    gaps += [float(z.distance(here)[0]) for z in zones]
    return min(gaps, default=math.inf)
