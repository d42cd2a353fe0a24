"""Perception on the simulated Hajj scenes (flight.sim): the paper's two scenarios and tracking quality.

**What "confirmed within 12 frames" means here.** The alarm is the collapsed person's track being confirmed with
both the ``stationary`` and the ``isolated_from`` relation: ``find(world, class_='person',
relation='isolated_from')`` returns it and it is ``stationary``. It must be up within 12 frames (0.4 s at 30 Hz)
of the casualty being *in view* in the sense isolation needs: the body and its surroundings out to the relation's
view margin (3 m) in the picture. Before that, nobody can tell a person alone from the first of a group coming
into view: on the normal scene, the first of the four people in the shade did look alone for a few frames until
the margin was introduced (see :mod:`agentic_core.perception.scene_graph`). By then the track has been going
since the body first showed at the picture's edge (0.6 s earlier at 5 m/s), so its stillness is established;
the frame counts from that first appearance and the track's age are printed too, and must stay under 1 s.

**The tension with the mission's trigger.** ``missions/hajj_emergency.yaml`` fires on ``stationary_s >=
params.still_s`` (10 s). ``stationary_s`` is observed time: counted from the track's first frame while the person
stays motionless, never guessed for before. At the mission's 30 m and the default 5 m/s cruise a point stays in
the camera's 30 m deep footprint for about 6 s, so a straight pass can confirm the casualty (the 12-frame alarm)
but cannot reach 10 s: the trigger fires once the aircraft keeps the person in view long enough (hovering, slower
legs, or a lower ``still_s``). Both halves are tested: the alarm on a pass, the trigger on a hover.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from agentic_core.contracts.geodesy import local_offset
from agentic_core.contracts.polygon import distance_to_edge, points_in_polygon
from agentic_core.mission.expressions import Expression
from agentic_core.mission.functions import find
from agentic_core.mission.templates import render
from agentic_core.perception.metrics import TrackingScore
from agentic_core.perception.scene_graph import RelationConfig
from agentic_core.perception.world_model import WorldModel, WorldObject
from flight.camera import footprint
from flight.sim.scene_file import load_scene
from flight.sim.scene_gen import generate_scene

from .flyover import Leg, fly

CASUALTY = "P-12"
CASUALTY_AT = (150.0, 14.0)
TRIGGER = "find(world, class_='person', stationary_s__gte=params.still_s, relation='isolated_from')"


def alarms(world: WorldModel) -> list[WorldObject]:
    """Confirmed people both isolated and stationary: the 12-frame alarm."""
    still = {r.subj for r in world.relations if r.pred == "stationary"}
    return [o for o in find(world, class_="person", relation="isolated_from") if o.id in still]


@pytest.mark.slow
def test_emergency_casualty_confirmed_within_12_frames() -> None:
    scene = load_scene("scenes/hajj_emergency.yaml")
    margin = RelationConfig().view_margin_m
    rows = []
    for seed in range(1, 5):
        in_view = judgeable = alarm = None
        age = 0
        # the mission's first northbound leg (east 0, 30 m up, 5 m/s), from 25 m before the casualty is in view
        for k, step in enumerate(fly(scene, [Leg((125.0, 0.0), (200.0, 0.0))], seed=seed)):
            if in_view is None and CASUALTY in step.truth:
                in_view = k
            corners = footprint(step.frame.spec, step.frame.pose)
            assert corners is not None
            at = np.array([CASUALTY_AT])
            inside = bool(points_in_polygon(at, corners)[0])
            # margin less 0.5 m: a lying body is placed ~0.35 m off, and judged where it is placed
            if judgeable is None and inside and distance_to_edge(at, corners)[0] >= margin - 0.5:
                judgeable = k
            raised = alarms(step.world)
            for o in raised:
                assert math.dist((o.pose.north, o.pose.east), CASUALTY_AT) < 1.5, f"false alarm {o}"
            if raised:
                alarm, age = k, raised[0].track_age_frames
                break
        assert in_view is not None and judgeable is not None and alarm is not None, (seed, in_view, judgeable)
        rows.append((seed, alarm - judgeable + 1, alarm - in_view + 1, age))
    print("\nseed | alarm on frame n: of the casualty and its surroundings in view | of it showing | track age")
    for row in rows:
        print("  {} | {:>3} | {:>3} | {:>3}".format(*row))
    assert all(n <= 12 for _, n, _, _ in rows)
    assert all(age <= 30 for *_, age in rows)  # under 1 s from its first detection


@pytest.mark.slow
def test_emergency_trigger_fires_while_the_casualty_stays_in_view() -> None:
    """Hovering 10 m short of the casualty, the mission's own trigger fires once 10 s have been observed, and the
    alert's text gets the casualty's position."""
    scene = load_scene("scenes/hajj_emergency.yaml")
    trigger = Expression.parse(TRIGGER)
    fired_at = None
    for step in fly(scene, [Leg((140.0, 0.0), (140.0, 0.0), speed_mps=0.0, hover_s=11.0)], seed=1, with_truth=False):
        found = trigger.evaluate({"world": step.world, "params": {"still_s": 10}})
        if found:
            fired_at = step.frame.time_s
            event = found[0]
            break
    assert fired_at is not None
    print(f"\ntrigger fired at t={fired_at:.2f} s on {event.id}, stationary_s={event.stationary_s:.2f}")
    assert 10.0 <= fired_at < 10.5 and event.stationary_s >= 10.0
    north, east = local_offset(scene.home.lat_deg, scene.home.lon_deg, event.pose.lat, event.pose.lon)
    assert math.dist((north, east), CASUALTY_AT) < 1.0
    subject = render("Collapsed pilgrim at ${event.pose.lat}, ${event.pose.lon}", {"event": event})
    assert subject.startswith("Collapsed pilgrim at 21.41")


@pytest.mark.slow
def test_normal_patrol_raises_no_alarm() -> None:
    """The northbound leg over the normal scene with thin crowds, from south of home to past the shade (50 s, 1,500
    frames: people walking and standing far apart — many chances to look alone — and four people sitting and
    lying together in the shade), then back south over the shade group (people come into view from the other
    side). No one is isolated and stationary, ever; the trigger never fires. (The full-density scene is the same
    but for the crowd, and ten times slower to simulate.)"""
    scene = load_scene("tests/agentic_core/run/scenes/small_normal.yaml")
    trigger = Expression.parse(TRIGGER)
    raised: dict[str, tuple[float, float, float]] = {}
    frames = objects = 0
    legs = [Leg((-50.0, 0.0), (200.0, 0.0)), Leg((120.0, 0.0), (20.0, 0.0))]
    for step in fly(scene, legs, seed=1, with_truth=False):
        frames += 1
        objects += len(step.world.objects)
        for o in alarms(step.world):
            raised.setdefault(o.id, (step.frame.time_s, o.pose.north, o.pose.east))
        assert not trigger.evaluate({"world": step.world, "params": {"still_s": 10}})
    print(f"\nnormal patrol: {frames} frames, {objects / frames:.0f} objects per frame, alarms: {raised or 'none'}")
    assert raised == {}


def score_generated(seed: int, density: float, frames: int) -> tuple[TrackingScore, float]:
    scene = generate_scene(seed, density=density, casualties=1, distractors=4)
    score = TrackingScore(max_distance_m=1.0)
    detected = seen = 0
    leg = Leg((-60.0, 0.0), (-60.0 + 5.0 * frames / 30.0, 0.0))
    for step in fly(scene, [leg], seed=seed):
        score.add(step.truth, step.confirmed)
        hits = {d.truth_id for d in step.detections}
        detected += sum(1 for t in step.truth if t in hits)
        seen += len(step.truth)
    return score, detected / seen


# Thresholds by density. Identity switches: the simulated crowds are placed uniformly, without keeping apart, so
# people walk through each other, and for 1 - exp(-pi * density * 0.3²) of them (8 % at 0.3 /m², 25 % at 1,
# 51 % at 2.5) someone is within 0.3 m, closer than boxes can tell apart. Position RMSE: a person's box centre
# is cast at 0.85 m, right for the upright (most) and up to 0.7·offset/height off for the sitting and lying; and
# the truth is matched within 1 m while neighbours are 1.8, 1.0 and 0.63 m apart at these densities, so in the
# dense crowd some matches pair a track with a neighbour. Recall: at least the detector's own (coasting through
# misses makes up for the two frames a track needs to be confirmed); precision: a confirmed track is a person.
@pytest.mark.slow
@pytest.mark.parametrize(
    ("seed", "density", "max_rmse_m", "max_switches_per_1000"),
    [(3, 0.3, 0.25, 5.0), (5, 1.0, 0.35, 20.0), (11, 2.5, 0.45, 40.0)],
)
def test_tracking_quality_on_generated_scenes(
    seed: int, density: float, max_rmse_m: float, max_switches_per_1000: float
) -> None:
    score, detector_recall = score_generated(seed, density, frames=240)
    print(f"\n[generated seed {seed}, {density} /m²] {score.summary()}, detector recall {detector_recall:.3f}")
    assert score.rmse_m <= max_rmse_m
    assert score.recall >= detector_recall
    assert score.precision >= 0.95
    assert score.id_switches_per_1000 <= max_switches_per_1000
