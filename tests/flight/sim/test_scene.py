"""The scene: its models and checks, the crowd's motion, the generator's ground truth and the shipped scenes."""

import math
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.spatial import cKDTree

from flight.camera import CameraPose, CameraSpec, footprint
from flight.sim.environment import Home
from flight.sim.scene import SceneState
from flight.sim.scene_file import dump_scene, load_scene
from flight.sim.scene_gen import generate_scene, generate_scenes
from flight.sim.scene_model import (
    NE,
    Actor,
    Circle,
    Flow,
    GroundTruth,
    Landmark,
    Scene,
    Zone,
    expected_severity,
)

REPO = Path(__file__).resolve().parents[3]
SCENES = REPO / "scenes"


def rect(n0, n1, e0, e1):
    return [NE(north=n0, east=e0), NE(north=n1, east=e0), NE(north=n1, east=e1), NE(north=n0, east=e1)]


def road_scene(seed=3, **extra):
    """A 200×20 m road flowing north at 1.2 m/s, plus whatever actors ``extra`` adds."""
    road = Zone(id="Z-road", polygon=rect(-100, 100, 0, 20), density=0.5, flow=Flow(heading_deg=0, speed_mps=1.2))
    return Scene(id="road", seed=seed, zones=[road], **extra)


# --- motion -----------------------------------------------------------------------------------------------------


def test_the_same_seed_moves_everyone_the_same_way():
    a, b = SceneState(road_scene()), SceneState(road_scene())
    for state in (a, b):
        state.advance_to(20.0)
    assert a.ids == b.ids
    assert np.array_equal(a.positions, b.positions)
    assert np.array_equal(a.velocities, b.velocities)
    c = SceneState(road_scene(seed=4))
    assert not np.array_equal(c.positions[: len(a)], a.positions[: len(c)])


def test_walkers_follow_the_flow_and_stay_in_their_zone():
    scene = road_scene()
    state = SceneState(scene)
    walkers = np.flatnonzero(np.array(state.behaviours) == "walking")
    assert len(walkers) > 800  # 0.5/m² × 4,000 m², 90 % walking
    start = state.positions[walkers].copy()
    generations = state.generations.copy()
    zone = scene.zones[0]
    for t in np.arange(1.0, 31.0, 1.0):
        state.advance_to(float(t))
        assert zone.contains(state.positions[walkers]).all()
    kept = walkers[state.generations[walkers] == generations[walkers]]  # those who did not leave and re-enter
    moved = state.positions[kept] - start[state.generations[walkers] == generations[walkers]]
    # personal speeds 1.2 × U(0.8, 1.2) m/s, heading offset N(0, 14°): E[cos] = exp(-σ²/2), 1.165 m/s northwards;
    # 8 % covers the faster walkers who left (excluded here) and the mean of ~900 jittered walks
    assert moved[:, 0].mean() / 30.0 == pytest.approx(1.2 * math.exp(-(math.radians(14) ** 2) / 2), rel=0.08)
    assert abs(moved[:, 1].mean()) < 1.0
    assert np.abs(state.velocities[walkers, 0]).mean() > 0.9


def test_walkers_leaving_downstream_come_back_upstream_as_new_pilgrims():
    state = SceneState(road_scene())
    n, persons, first_ids = len(state), state.person_mask.sum(), list(state.ids)
    state.advance_to(60.0)  # at 1.2 m/s, a sixth of the 200 m road's walkers have left by now
    renewed = np.flatnonzero(state.generations > 0)
    assert len(renewed) > 50
    assert len(state) == n and state.person_mask.sum() == persons  # the density holds
    assert len(set(state.ids)) == n  # new ids, never reused
    assert all(state.index_of(state.ids[i]) == i for i in renewed)
    with pytest.raises(KeyError):
        state.index_of(first_ids[renewed[0]])  # who left is gone
    assert state.velocities[renewed, 0].min() > 0.0  # walking on, not the jump back


def test_collapsed_and_parked_do_not_move_standing_people_sway_a_little():
    actors = [
        Actor(id="P-C", position=NE(north=0, east=-40), behaviour="collapsed"),
        Actor(id="P-S", position=NE(north=10, east=-40), behaviour="standing"),
        Actor(id="V-1", class_name="vehicle", position=NE(north=20, east=-40), behaviour="parked"),
        Actor(id="P-R", position=NE(north=30, east=-40), behaviour="running", velocity=NE(north=0, east=-3.0)),
    ]
    gt = GroundTruth(expected_severity="critical", casualties=["P-C"], isolated=["P-C"], isolation_m=5)
    state = SceneState(road_scene(actors=actors, ground_truth=gt))
    start = state.positions.copy()
    track = []
    for t in np.arange(0.5, 20.5, 0.5):
        state.advance_to(float(t))
        track.append(state.positions.copy())
        for ident in ("P-C", "V-1"):
            i = state.index_of(ident)
            assert (state.positions[i] == start[i]).all() and (state.velocities[i] == 0).all()
    sway = np.array(track)[:, state.index_of("P-S")] - start[state.index_of("P-S")]
    assert 0.005 < np.abs(sway).max() < 0.2  # centimetres: 3 cm std
    runner = state.index_of("P-R")
    assert state.positions[runner, 1] == pytest.approx(-40 - 3.0 * 20, abs=3.0)  # keeps its velocity
    snapshot = state.actor("P-C")
    assert snapshot.behaviour == "collapsed" and snapshot.position == actors[0].position


def test_runners_are_faster_and_milling_crowds_stay_in_their_circle():
    plaza = Zone(
        id="Z-plaza",
        kind="plaza",
        circle=Circle(center=NE(north=0, east=-60), radius_m=15),
        density=1.0,
        mix={"walking": 0.5, "running": 0.5},
    )
    state = SceneState(Scene(id="plaza", zones=[plaza]))
    kinds = np.array(state.behaviours)
    for t in range(1, 21):
        state.advance_to(float(t))
        movers = np.isin(kinds, ["walking", "running"])
        assert plaza.contains(state.positions[movers]).all()
    speed = np.linalg.norm(state.velocities, axis=1)
    assert speed[kinds == "running"].mean() > 2.0 * speed[kinds == "walking"].mean()


def test_the_clearance_shortcut_finds_exactly_the_walkers_that_left_their_zone(monkeypatch):
    """Stepping tests only the walkers that moved at least their distance to the edge; that must give, step by step,
    the walkers a test of every one would: in a zigzag corridor (walkers always near an edge), a milling circle and a
    flowing road, with runners."""
    zigzag = [NE(north=0, east=0), NE(north=30, east=6), NE(north=0, east=12), NE(north=30, east=18),
              NE(north=34, east=18), NE(north=4, east=12), NE(north=34, east=6), NE(north=4, east=0)]  # fmt: skip
    zones = [
        Zone(id="Z-zig", polygon=zigzag, density=1.5, flow=Flow(heading_deg=90, speed_mps=1.0),
             mix={"walking": 0.7, "running": 0.3}),
        Zone(id="Z-mill", circle=Circle(center=NE(north=-40, east=0), radius_m=6), density=1.0, mix={"walking": 1}),
        Zone(id="Z-road", polygon=rect(50, 90, 0, 8), density=0.8, flow=Flow(heading_deg=0, speed_mps=1.4)),
    ]  # fmt: skip
    state = SceneState(Scene(id="edges", seed=11, zones=zones))
    shortcut = SceneState._stepped_out
    checked: list[int] = []
    skipped: list[int] = []

    def every_walker_tested(self, zone, rows, new):
        out = shortcut(self, zone, rows, new)
        every = self._zone_rows[[z.id for z in zones].index(zone.id)]
        assert np.array_equal(out, every[~zone.contains(new[every])])  # none of those skipped had left
        checked.append(len(out))
        skipped.append(len(every) - len(rows))
        return out

    monkeypatch.setattr(SceneState, "_stepped_out", every_walker_tested)
    state.advance_to(40.0)
    assert len(checked) == 3 * 1200 and sum(checked) > 100  # walkers did leave, and each step agreed
    assert sum(skipped) > sum(checked)  # and the shortcut did skip most tests


@pytest.mark.parametrize("zone", [Zone(id="Z-c", circle=Circle(center=NE(north=3, east=-2), radius_m=6)),
                                  Zone(id="Z-p", polygon=rect(0, 10, 0, 4))], ids=["circle", "polygon"])  # fmt: skip
def test_inside_and_clearance_is_contains_and_clearance_exactly(zone):
    """The crowd asks both at once; the answers must be the two methods' own, bit for bit, on edges and corners too."""
    rng = np.random.default_rng(5)
    points = np.concatenate([rng.uniform(-12, 14, (500, 2)), zone.vertices(), [[3.0, 4.0], [np.nan, 1.0]]])
    inside, clearance = zone.inside_and_clearance(points)
    assert inside.tobytes() == zone.contains(points).tobytes() and inside.any() and not inside.all()
    assert clearance.tobytes() == zone.clearance(points).tobytes()


def test_a_thousand_actors_step_as_arrays():
    scene = generate_scene(5, persons=1500, casualties=1, distractors=4)
    state = SceneState(scene)
    assert len(state) >= 1500 + 5
    state.advance_to(1.0)
    corners = state.corners()
    assert corners.shape == (len(state), 8, 3)
    assert (corners[:, :4, 2] == 0).all() and (corners[:, 4:, 2] < 0).all()


# --- the model's checks -----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"ground_truth": GroundTruth(casualties=["P-9"])}, "ground_truth.casualties[0]: no actor 'P-9'"),
        ({"ground_truth": GroundTruth()}, "P-0 is collapsed but not in ground_truth.casualties"),
        (
            {"ground_truth": GroundTruth(expected_severity="none", casualties=["P-0"])},
            "'none' with casualties; high or critical",
        ),
        (
            {"ground_truth": GroundTruth(expected_severity="high", casualties=["P-0"], isolated=["P-0"], persons=3)},
            "ground_truth.persons: the scene holds 2001 persons, not 3",
        ),
    ],
)
def test_inconsistent_ground_truth_is_refused_naming_the_field(change, message):
    actors = [Actor(id="P-0", position=NE(north=0, east=-30), behaviour="collapsed")]
    with pytest.raises(ValidationError, match=message.replace("[", r"\[").replace("]", r"\]")):
        road_scene(actors=actors, **change)


def test_a_casualty_near_the_crowd_is_not_isolated():
    actors = [Actor(id="P-0", position=NE(north=0, east=-10), behaviour="collapsed")]
    gt = GroundTruth(expected_severity="critical", casualties=["P-0"], isolated=["P-0"])
    with pytest.raises(ValidationError, match=r"P-0 is 10.0 m from others \(isolation_m 15\)"):
        road_scene(actors=actors, ground_truth=gt)
    fine = road_scene(actors=actors, ground_truth=gt.model_copy(update={"isolated": [], "expected_severity": "high"}))
    assert expected_severity(fine) == "high"


def test_duplicate_ids_unknown_zones_and_vehicles_that_walk_are_refused():
    with pytest.raises(ValidationError, match=r"id 'Z-road' is already used by zones\[0\]"):
        road_scene(landmarks=[Landmark(id="Z-road", kind="road", position=NE(north=0, east=0))])
    with pytest.raises(ValidationError, match="no zone 'Z-x'"):
        road_scene(actors=[Actor(id="P-1", position=NE(north=0, east=5), behaviour="walking", zone="Z-x")])
    with pytest.raises(ValidationError, match="a vehicle can be driving, parked, not walking"):
        road_scene(actors=[Actor(id="V-1", class_name="vehicle", position=NE(north=0, east=-50), behaviour="walking")])
    with pytest.raises(ValidationError, match="'collapsed' cannot be in a crowd mix"):
        Scene(id="s", zones=[Zone(id="Z", circle=Circle(center=NE(north=0, east=0), radius_m=5), mix={"collapsed": 1})])


# --- generated scenes -------------------------------------------------------------------------------------------


def _nearest_other(state: SceneState, row: int) -> float:
    others = np.delete(state.positions, row, axis=0)
    distance, _ = cKDTree(others).query(state.positions[row])
    return float(distance)


def test_generated_scenes_carry_consistent_ground_truth():
    scenes = generate_scenes(44, seed=11)
    assert len({s.id for s in scenes}) == 44
    for scene in scenes:
        gt = scene.ground_truth
        state = SceneState(scene)
        assert gt.persons == scene.persons == int(state.person_mask.sum())
        assert gt.expected_severity == expected_severity(scene)
        for t in (0.0, 15.0, 30.0):  # isolated casualties stay isolated while the crowd moves (1 s steps)
            state.advance_to(t, max_dt=1.0)
            for ident in gt.isolated:
                assert _nearest_other(state, state.index_of(ident)) > gt.isolation_m, (scene.id, ident, t)
        for ident in gt.casualties:
            assert scene.actor(ident).behaviour == "collapsed" and scene.actor(ident).class_name == "person"
        shades = [lm.center for lm in scene.landmarks if lm.kind == "shade"]
        for ident in gt.distractors:
            actor = scene.actor(ident)
            assert ident not in gt.casualties and actor.behaviour in ("sitting", "resting")
            assert min(math.dist((actor.position.north, actor.position.east), (s.north, s.east)) for s in shades) < 4
        collapsed = {a.id for a in scene.actors if a.behaviour == "collapsed"}
        assert collapsed == set(gt.casualties)


def test_generated_campaigns_vary_and_repeat():
    scenes = generate_scenes(44, seed=11)
    assert scenes == generate_scenes(44, seed=11)
    assert scenes != generate_scenes(44, seed=12)
    casualties = [len(s.ground_truth.casualties) - len([a for a in s.actors if a.id.startswith("P-X")]) for s in scenes]
    assert set(casualties) == {0, 1, 2, 3}
    densities = [s.zones[0].density for s in scenes]
    assert max(densities) / min(densities) > 10
    assert len({len(s.ground_truth.distractors) for s in scenes}) >= 5
    severities = {s.ground_truth.expected_severity for s in scenes}
    assert {"none", "critical"} <= severities


def test_generate_scene_takes_what_it_is_given():
    scene = generate_scene(9, casualties=0, distractors=0, persons=1000)
    assert scene.zones[0].persons == 1000
    assert scene.ground_truth.casualties == [] and scene.ground_truth.expected_severity in ("none", "low")
    crowded = generate_scene(9, casualties=0, density=2.2, distractors=2, crowd_casualties=1)
    assert crowded.ground_truth.expected_severity == "high" and crowded.ground_truth.isolated == []
    assert generate_scene(9, casualties=2).ground_truth.expected_severity == "critical"
    with pytest.raises(ValueError, match="cannot be negative"):
        generate_scene(1, casualties=-1)


def test_scenes_round_trip_through_yaml():
    for scene in [generate_scene(4, casualties=2, distractors=5), load_scene(SCENES / "hajj_emergency.yaml")]:
        assert load_scene(dump_scene(scene), file="dumped.yaml") == scene


# --- the shipped scenes -----------------------------------------------------------------------------------------


def test_the_paper_scenarios_ship_with_their_ground_truth():
    normal = load_scene(SCENES / "hajj_normal.yaml")
    emergency = load_scene(SCENES / "hajj_emergency.yaml")
    assert normal.ground_truth.expected_severity == "none" and normal.ground_truth.casualties == []
    assert emergency.ground_truth.expected_severity == "critical"
    assert emergency.ground_truth.casualties == emergency.ground_truth.isolated == ["P-12"]
    assert normal.ground_truth.distractors == emergency.ground_truth.distractors != []
    assert normal.home.to_home() == Home()  # the simulator's default home, where the missions fly
    assert emergency.persons == normal.persons + 1


def test_the_emergency_missions_leg_passes_over_the_casualty():
    """missions/hajj_emergency.yaml flies lon 39.8933 between lat 21.4106 and 21.4160 at 30 m."""
    scene = load_scene(SCENES / "hajj_emergency.yaml")
    p12 = scene.actor("P-12").position
    lat, lon = scene.geodetic(p12.north, p12.east)
    assert 21.4106 < lat < 21.4160 and lon > 39.8933  # east of the flight line
    ground = footprint(CameraSpec(), CameraPose(north_m=p12.north, east_m=0.0, down_m=-30.0))
    assert ground is not None and ground[:, 1].min() < p12.east < ground[:, 1].max()
    road = next(z for z in scene.zones if z.id == "Z-road")
    assert ground[:, 1].min() < road.vertices()[:, 1].max()  # the road's crowd is in the same view
