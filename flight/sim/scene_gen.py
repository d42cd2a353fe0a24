"""Scenes drawn at random from a seed, for evaluation campaigns: Mina-like layouts with varied crowds, casualties
and distractors, each carrying its ground truth.

Every generated scene is laid out under the tutorial missions' flight line (east = 0, the legs of
``missions/hajj_emergency.yaml``) between north -120 and +120 m:

* a **walkway** 12–24 m wide, its near edge 3–8 m to one side of the flight line, 240 m long, flowing north or
  south at 0.8–1.4 m/s, at ``density`` persons/m² (drawn log-uniformly from 0.1–2.5 when not given);
* on the far side of the walkway, with probability 1/2, a milling **plaza** (a circle 15–30 m across) at half to
  the full density, a **medical post** with, half the time, an ambulance parked beside it, and one to three
  **shade** awnings where the ``distractors`` sit (70 %) or rest lying down (30 %), in groups of up to four;
* on the other side of the flight line, the ``casualties``: collapsed persons each at least 18 m (3 m more than
  the ground truth's 15 m isolation distance) from every zone, each other and everyone else, within 25 m of the
  flight line so a 30 m pass sees them; beyond them a sparse tent **camp**;
* ``crowd_casualties`` collapsed persons inside the walkway (not isolated: severity ``high`` when they are the only
  casualties).

The ground truth's severity follows :func:`~flight.sim.scene_model.severity_rule`. At most nine isolated
casualties fit the layout.

>>> scene = generate_scene(7, density=0.5, casualties=1, distractors=3)
>>> len(scene.ground_truth.isolated), len(scene.ground_truth.distractors), scene.ground_truth.expected_severity
(1, 3, 'critical')
>>> scenes = generate_scenes(44, seed=1)
>>> len(scenes), sum(bool(s.ground_truth.casualties) for s in scenes)
(44, 28)
"""

from __future__ import annotations

import math

import numpy as np

from flight.sim.scene_model import NE, Actor, Circle, Flow, GroundTruth, Landmark, Scene, Zone, severity_rule

LENGTH_M = 240.0
DENSITY_RANGE = (0.1, 2.5)
ISOLATION_MARGIN_M = 3.0
CASUALTY_PATTERN = (0, 1, 1, 0, 2, 1, 0, 3)
"""Casualties per scene in a campaign, in turn: 3/8 of the scenes have none, the rest one to three."""


def generate_scene(
    seed: int,
    *,
    density: float | None = None,
    casualties: int | None = None,
    distractors: int | None = None,
    crowd_casualties: int = 0,
    persons: int | None = None,
    scene_id: str | None = None,
) -> Scene:
    """One scene drawn from ``seed``; what is not given is drawn too.

    ``persons``, when given, sets the walkway's density so that it holds that many pilgrims (e.g. 1,000 for a
    perception benchmark) instead of ``density``.
    """
    rng = np.random.default_rng([seed, 7])
    k = int(rng.integers(0, 3)) if casualties is None else casualties
    d = int(rng.integers(0, 9)) if distractors is None else distractors
    if min(k, d, crowd_casualties) < 0:
        raise ValueError("casualties, distractors and crowd_casualties cannot be negative")
    side = 1.0 if rng.random() < 0.5 else -1.0  # the walkway's side of the flight line
    gap, width = rng.uniform(3.0, 8.0), rng.uniform(12.0, 24.0)
    lo, hi = gap, gap + width
    north0, north1 = -LENGTH_M / 2.0, LENGTH_M / 2.0
    area = LENGTH_M * width
    if persons is not None:
        rho = persons / area
    elif density is not None:
        rho = density
    else:
        rho = math.exp(rng.uniform(math.log(DENSITY_RANGE[0]), math.log(DENSITY_RANGE[1])))
    heading = float((0.0 if rng.random() < 0.5 else 180.0) + rng.uniform(-5.0, 5.0))
    walkway = Zone(
        id="Z-walkway",
        kind="walkway",
        name="Pilgrims' road",
        polygon=_rect(north0, north1, side * lo, side * hi),
        density=rho,
        flow=Flow(heading_deg=heading, speed_mps=float(rng.uniform(0.8, 1.4))),
        mix={"walking": 0.9, "standing": 0.08, "running": 0.02}
        if rng.random() < 0.3
        else {"walking": 0.92, "standing": 0.08},
    )
    zones = [walkway]
    landmarks = [
        Landmark(id="Road-1", kind="road", name="Pilgrims' road", polygon=walkway.polygon),
        Landmark(id="Exit-1", kind="exit", position=NE(north=north1, east=side * (lo + hi) / 2)),
        Landmark(id="Exit-2", kind="exit", position=NE(north=north0, east=side * (lo + hi) / 2)),
    ]
    actors: list[Actor] = []
    far = hi + 6.0  # beyond the walkway, on its side
    if rng.random() < 0.5:
        r = float(rng.uniform(7.5, 15.0))
        center = NE(north=float(rng.uniform(-60.0, 60.0)), east=side * (hi + 25.0 + r))
        zones.append(
            Zone(
                id="Z-plaza",
                kind="plaza",
                circle=Circle(center=center, radius_m=r),
                density=rho * float(rng.uniform(0.5, 1.0)),
                mix={"walking": 0.5, "standing": 0.4, "sitting": 0.1},
            )
        )
    med = NE(north=float(rng.uniform(-100.0, 100.0)), east=side * (far + 2.0))
    landmarks.append(Landmark(id="Med-1", kind="medical_post", name="Medical post", position=med))
    if rng.random() < 0.5:
        actors.append(
            Actor(
                id="V-01",
                class_name="vehicle",
                behaviour="parked",
                position=NE(north=med.north + 6.0, east=med.east + side * 2.0),
                heading_deg=float(rng.choice([0.0, 180.0])),
            )
        )
    n_shade = 0 if d == 0 else min(3, 1 + d // 4)
    shades = [NE(north=float(n), east=side * (far + float(rng.uniform(0.0, 12.0)))) for n in _spread(rng, n_shade)]
    for j, shade in enumerate(shades):
        landmarks.append(Landmark(id=f"Shade-{j + 1}", kind="shade", name="Awning", polygon=_around(shade, 4.0)))
    for i in range(d):
        shade = shades[i % len(shades)]
        slot = i // len(shades)
        angle = slot * math.pi / 2.0 + rng.uniform(-0.3, 0.3)
        radius = 1.5 + slot // 4  # four to a ring around the shade's centre
        actors.append(
            Actor(
                id=f"P-D{i + 1}",
                behaviour="sitting" if rng.random() < 0.7 else "resting",
                position=NE(north=shade.north + radius * math.cos(angle), east=shade.east + radius * math.sin(angle)),
                heading_deg=float(rng.uniform(0.0, 360.0)),
            )
        )
    clearance = 15.0 + ISOLATION_MARGIN_M
    offsets = rng.uniform(max(0.0, clearance - lo), max(0.0, clearance - lo) + 10.0, k)
    for i, (north, off) in enumerate(zip(_spread(rng, k, min_gap=clearance + 2.0), offsets, strict=True)):
        actors.append(
            Actor(
                id=f"P-C{i + 1}",
                behaviour="collapsed",
                position=NE(north=float(north), east=-side * float(off)),
                heading_deg=float(rng.uniform(0.0, 360.0)),
            )
        )
    camp_edge = (float(offsets.max()) if k else 10.0) + clearance
    zones.append(
        Zone(
            id="Z-camp",
            kind="camp",
            name="Tent camp",
            polygon=_rect(north0, north1, -side * camp_edge, -side * (camp_edge + 50.0)),
            density=float(rng.uniform(0.02, 0.08)),
            mix={"standing": 0.4, "sitting": 0.35, "walking": 0.2, "resting": 0.05},
        )
    )
    for j in range(3):
        pos = NE(north=float(rng.uniform(north0 + 10, north1 - 10)), east=-side * (camp_edge + 10.0 + 15.0 * j))
        landmarks.append(Landmark(id=f"Tent-{j + 1}", kind="tent", position=pos))
    for i in range(crowd_casualties):
        (point,) = walkway.sample(1, rng)
        actors.append(
            Actor(id=f"P-X{i + 1}", behaviour="collapsed", position=NE(north=float(point[0]), east=float(point[1])))
        )
    isolated = [a.id for a in actors if a.id.startswith("P-C")]
    casualty_ids = [*isolated, *(a.id for a in actors if a.id.startswith("P-X"))]
    truth = GroundTruth(
        expected_severity=severity_rule(bool(isolated), bool(casualty_ids), max(z.density for z in zones)),
        casualties=casualty_ids,
        isolated=isolated,
        distractors=[a.id for a in actors if a.id.startswith("P-D")],
        persons=sum(a.class_name == "person" for a in actors) + sum(z.persons for z in zones),
        notes=f"generated: density {rho:.2f}/m², {k} isolated and {crowd_casualties} crowd casualties, {d} distractors",
    )
    return Scene(
        id=scene_id or f"gen-{seed}",
        description="Generated Mina-like scene (flight.sim.scene_gen)",
        seed=seed,
        actors=actors,
        zones=zones,
        landmarks=landmarks,
        ground_truth=truth,
    )


def generate_scenes(n: int = 44, seed: int = 0) -> list[Scene]:
    """``n`` varied scenes for a campaign (the paper's had 44): casualties cycle through
    :data:`CASUALTY_PATTERN`, densities are stratified over the log of :data:`DENSITY_RANGE`, distractors 0–8, and
    one scene in six also has a casualty inside the crowd."""
    rng = np.random.default_rng([seed, 44])
    strata = rng.permutation(n)
    lo, hi = math.log(DENSITY_RANGE[0]), math.log(DENSITY_RANGE[1])
    seeds = [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(n)]
    scenes = []
    for i in range(n):
        density = math.exp(lo + (hi - lo) * (strata[i] + rng.random()) / n)
        scenes.append(
            generate_scene(
                seeds[i],
                density=density,
                casualties=CASUALTY_PATTERN[i % len(CASUALTY_PATTERN)],
                distractors=int(rng.integers(0, 9)),
                crowd_casualties=int(rng.random() < 1.0 / 6.0),
                scene_id=f"campaign-{seed}-{i + 1:02d}",
            )
        )
    return scenes


def _rect(n0: float, n1: float, e0: float, e1: float) -> list[NE]:
    e0, e1 = min(e0, e1), max(e0, e1)
    return [NE(north=n0, east=e0), NE(north=n1, east=e0), NE(north=n1, east=e1), NE(north=n0, east=e1)]


def _around(center: NE, half: float) -> list[NE]:
    return _rect(center.north - half, center.north + half, center.east - half, center.east + half)


def _spread(rng: np.random.Generator, count: int, min_gap: float = 30.0) -> list[float]:
    """``count`` northings in -100..100 m at least ``min_gap`` apart (evenly spaced slots, jittered)."""
    if count == 0:
        return []
    slot = 200.0 / count
    if slot < min_gap:
        raise ValueError(f"{count} items do not fit 200 m at {min_gap:g} m apart")
    jitter = (slot - min_gap) / 2.0
    return [float(-100.0 + slot * (i + 0.5) + rng.uniform(-jitter, jitter)) for i in range(count)]
