"""Relation correctness on hand-built scenes: near, isolated_from, inside, moving_toward, stationary."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from agentic_core.contracts.polygon import distance_to_edge, points_in_polygon
from agentic_core.contracts.world_model import Landmark as LandmarkContract
from agentic_core.perception.scene_graph import Rel, RelationConfig, SceneGraph, as_landmark
from agentic_core.perception.tracker import CONFIRMED, LOST, TENTATIVE, TrackTable
from flight.sim.scene_model import NE, Circle, Landmark, Zone


def table(
    rows: list[tuple[str, float, float]],
    *,
    vel: dict[str, tuple[float, float]] | None = None,
    still: dict[str, float] | None = None,
    state: dict[str, int] | None = None,
    classes: dict[str, str] | None = None,
    vel_sigma: float = 0.05,
    hits: dict[str, int] | None = None,
) -> TrackTable:
    n = len(rows)
    x = np.zeros((n, 4))
    P = np.array([np.diag([0.01, 0.01, vel_sigma**2, vel_sigma**2])] * n).reshape(n, 4, 4)
    ids = [r[0] for r in rows]
    for k, (ident, north, east) in enumerate(rows):
        x[k, :2] = north, east
        x[k, 2:] = (vel or {}).get(ident, (0.0, 0.0))
    return TrackTable(
        ids=ids,
        classes=[(classes or {}).get(i, "person") for i in ids],
        state=np.array([(state or {}).get(i, CONFIRMED) for i in ids], dtype=np.int8),
        x=x,
        P=P,
        age_frames=np.full(n, 100),
        stationary_s=np.array([(still or {}).get(i, 0.0) for i in ids]),
        conf=np.full(n, 0.8),
        last_seen=np.zeros(n),
        detected=np.ones(n, dtype=bool),
        boxes=np.zeros((n, 4)),
        detection_index=np.arange(n),
        recent_hits=np.array([(hits or {}).get(i, 8) for i in ids]),
    )


def rels(relations: list[Rel], pred: str) -> set[tuple[str, str | None]]:
    return {(r.subj, r.obj) for r in relations if r.pred == pred}


def crowd(
    n_side: int, spacing: float, north0: float, east0: float, prefix: str = "C"
) -> list[tuple[str, float, float]]:
    return [
        (f"{prefix}{i}-{j}", north0 + i * spacing, east0 + j * spacing) for i in range(n_side) for j in range(n_side)
    ]


def test_isolated_from_the_crowd() -> None:
    people = [*crowd(6, 1.5, 0.0, 0.0), ("alone", 4.0, 25.0), ("edge", 4.0, 9.0)]
    out = SceneGraph().update(table(people))
    isolated = rels(out, "isolated_from")
    assert isolated == {("alone", "crowd")}  # "edge" is 1.5 m past the crowd's edge: beside it, not alone
    value = next(r.value for r in out if r.subj == "alone" and r.pred == "isolated_from")
    assert value == pytest.approx(16.0)  # to the nearest other person: "edge", at east 9


def test_isolation_needs_low_density_not_only_a_gap() -> None:
    """11 m from a packed crowd: nobody within 10 m, but 15 m around holds dozens of people."""
    people = [*crowd(10, 0.8, 0.0, 0.0), ("near_crowd", 3.6, 18.2)]
    assert rels(SceneGraph().update(table(people)), "isolated_from") == set()
    sparse = [("a", 0.0, 0.0), ("b", 0.0, 12.0), ("c", 12.0, 0.0)]  # 12 m apart: each alone
    assert {s for s, _ in rels(SceneGraph().update(table(sparse)), "isolated_from")} == {"a", "b", "c"}


def test_tentative_and_lost_people_count_as_neighbours_but_are_not_subjects() -> None:
    people = [("p", 0.0, 0.0), ("t", 0.0, 3.0), ("l", 30.0, 0.0)]
    out = SceneGraph().update(table(people, state={"t": TENTATIVE, "l": LOST}))
    assert rels(out, "isolated_from") == set()  # p has a (tentative) neighbour; t and l are not subjects
    out = SceneGraph().update(table([("p", 0.0, 0.0), ("l", 0.0, 4.0)], state={"l": LOST}))
    assert rels(out, "isolated_from") == set()  # seen a moment ago, 4 m away
    flash = table([("p", 0.0, 0.0), ("fp", 0.0, 3.0)], state={"fp": TENTATIVE}, hits={"fp": 1})
    assert rels(SceneGraph().update(flash), "isolated_from") == {("p", "crowd")}  # a one-frame detection is no one


def test_only_people_are_isolated_and_only_from_people() -> None:
    out = SceneGraph().update(table([("p", 0.0, 0.0), ("car", 0.0, 3.0)], classes={"car": "vehicle"}))
    assert rels(out, "isolated_from") == {("p", "crowd")}


def test_isolation_view_margin() -> None:
    """People nearer the footprint's edge than the margin (3 m by default) are not judged: their surroundings are
    partly out of sight; a track coasting out of sight never is."""
    footprint = np.array([[-15.0, -27.0], [15.0, -27.0], [15.0, 27.0], [-15.0, 27.0]])
    people = table([("centre", 0.0, 0.0), ("by_edge", 13.0, -20.0)])  # 2 m from the north edge
    default = SceneGraph().update(people, footprint=footprint)
    assert {s for s, _ in rels(default, "isolated_from")} == {"centre"}
    none = SceneGraph(RelationConfig(view_margin_m=0.0)).update(people, footprint=footprint)
    assert {s for s, _ in rels(none, "isolated_from")} == {"centre", "by_edge"}
    outside = SceneGraph(RelationConfig(view_margin_m=0.0)).update(table([("gone", 20.0, 0.0)]), footprint=footprint)
    assert rels(outside, "isolated_from") == set()
    unknown = SceneGraph().update(people)  # no footprint: everyone judged
    assert {s for s, _ in rels(unknown, "isolated_from")} == {"centre", "by_edge"}


def test_near_tracks_and_landmarks() -> None:
    people = [("a", 0.0, 0.0), ("b", 1.5, 0.0), ("c", 10.0, 0.0)]
    exit3 = as_landmark({"id": "Exit-3", "kind": "exit", "north": 15.0, "east": 0.0})
    out = SceneGraph().update(table(people), landmarks=[exit3])
    near = rels(out, "near")
    assert len({("a", "b"), ("b", "a")} & near) == 1  # each other's nearest within 2 m: one relation
    chain = rels(SceneGraph().update(table([("x", 0.0, 0.0), ("y", 1.0, 0.0), ("z", 2.5, 0.0)])), "near")
    assert chain == {("x", "y"), ("z", "y")}  # z's nearest is y, but y's is x: both kept
    assert ("c", "Exit-3") in near and ("a", "Exit-3") not in near  # 5 m vs 15 m (limit 10 m)
    assert not any(s == "c" and o in ("a", "b") for s, o in near)


def test_inside_a_polygon_and_a_circle_zone() -> None:
    shade = Landmark(
        id="Shade-1",
        kind="shade",
        polygon=[NE(north=60, east=5), NE(north=72, east=5), NE(north=72, east=13), NE(north=60, east=13)],
    )
    plaza = Zone(id="Z-gate", kind="plaza", circle=Circle(center=NE(north=0, east=100), radius_m=30), density=0.5)
    people = [("in_shade", 65.0, 9.0), ("by_shade", 65.0, 15.0), ("in_plaza", 10.0, 110.0), ("out", 0.0, 0.0)]
    out = SceneGraph().update(table(people), landmarks=[as_landmark(shade), as_landmark(plaza)])
    assert rels(out, "inside") == {("in_shade", "Shade-1"), ("in_plaza", "Z-gate")}
    near = rels(out, "near")
    assert ("by_shade", "Shade-1") in near and ("in_shade", "Shade-1") not in near  # inside is not "near"
    by = next(r.value for r in out if r.subj == "by_shade" and r.obj == "Shade-1" and r.pred == "near")
    assert by == pytest.approx(2.0)  # to the edge, not the centre


def test_a_landmark_that_changes_is_judged_by_its_new_shape() -> None:
    """The scene graph keeps each landmark's geometry between updates: a landmark moved, reshaped, turned into a
    circle or edited in place under the same id must be judged as it is now, never as it was."""
    graph = SceneGraph()
    people = table([("p", 5.0, 5.0)])
    shade = LandmarkContract(id="S", kind="shade", north=5.0, east=5.0, polygon=[[0, 0], [10, 0], [10, 10], [0, 10]])
    assert rels(graph.update(people, landmarks=[shade]), "inside") == {("p", "S")}
    moved = shade.model_copy(update={"polygon": [[20, 0], [30, 0], [30, 10], [20, 10]], "north": 25.0})
    assert rels(graph.update(people, landmarks=[moved]), "inside") == set()
    assert rels(graph.update(people, landmarks=[shade]), "inside") == {("p", "S")}
    assert shade.polygon is not None
    shade.polygon[1] = (4.0, 0.0)  # edited in place: the same list, another shape
    shade.polygon[2] = (4.0, 10.0)
    assert rels(graph.update(people, landmarks=[shade]), "inside") == set()
    ring = shade.model_copy(update={"polygon": None, "radius_m": 1.0, "north": 5.0, "east": 5.5})
    assert rels(graph.update(people, landmarks=[ring]), "inside") == {("p", "S")}


def test_moving_toward() -> None:
    gate = as_landmark({"id": "Gate-E", "kind": "gate", "north": 0.0, "east": 50.0})
    people = [("toward", 0.0, 0.0), ("away", 0.0, 10.0), ("askew", 0.0, 20.0), ("slow", 0.0, 30.0)]
    vel = {"toward": (0.2, 1.2), "away": (0.0, -1.2), "askew": (1.2, 1.2), "slow": (0.0, 0.2)}
    out = SceneGraph().update(table(people, vel=vel), landmarks=[gate])
    assert rels(out, "moving_toward") == {("toward", "Gate-E")}  # 9.5° off; askew is 45° off; slow is too slow


def test_moving_toward_needs_clear_motion() -> None:
    gate = as_landmark({"id": "G", "kind": "gate", "north": 0.0, "east": 50.0})
    noisy = table([("p", 0.0, 0.0)], vel={"p": (0.0, 0.9)}, vel_sigma=0.4)  # 0.9 - 2·0.4 < 0.5
    assert rels(SceneGraph().update(noisy, landmarks=[gate]), "moving_toward") == set()


def test_stationary() -> None:
    people = [("still", 0.0, 0.0), ("new", 0.0, 5.0), ("fast", 0.0, 10.0)]
    out = SceneGraph().update(table(people, still={"still": 12.0, "new": 0.1, "fast": 3.0}, vel={"fast": (1.0, 0.0)}))
    assert rels(out, "stationary") == {("still", None)}
    assert next(r.value for r in out if r.pred == "stationary") == 12.0


def test_the_graph_holds_nodes_edges_and_unary_relations() -> None:
    graph = SceneGraph()
    lm = as_landmark({"id": "Exit-3", "kind": "exit", "north": 2.0, "east": 0.0})
    graph.update(table([("P-01", 0.0, 0.0), ("P-02", 40.0, 0.0)], still={"P-01": 5.0}), landmarks=[lm])
    g = graph.graph
    assert g.nodes["P-01"]["kind"] == "track" and g.nodes["Exit-3"]["kind"] == "landmark"
    assert g.nodes["P-01"]["stationary"] == 5.0 and g.nodes["P-02"]["stationary"] is None
    assert g.has_edge("P-01", "Exit-3", key="near") and g.has_edge("ego", "P-01", key="observes")
    graph.update(table([("P-02", 40.0, 0.0)]), landmarks=[])  # P-01 deleted, landmark gone
    assert "P-01" not in graph.graph and "Exit-3" not in graph.graph and "P-02" in graph.graph


@pytest.mark.parametrize(
    "record",
    [
        {"id": "A", "kind": "exit", "north": 1, "east": 2},
        {"id": "A", "kind": "exit", "north_m": 1, "east_m": 2},
        SimpleNamespace(id="A", kind="exit", position=SimpleNamespace(north=1, east=2)),
        Landmark(id="A", kind="exit", position=NE(north=1, east=2)),
    ],
)
def test_as_landmark_reads_points_of_any_shape(record: object) -> None:
    lm = as_landmark(record)
    assert (lm.id, lm.kind, lm.north, lm.east, lm.polygon) == ("A", "exit", 1.0, 2.0, None)


def test_as_landmark_reads_zones_and_refuses_junk() -> None:
    zone = Zone(id="Z", kind="plaza", circle=Circle(center=NE(north=3, east=4), radius_m=5), density=0.1)
    lm = as_landmark(zone)
    assert (lm.north, lm.east, lm.radius_m, lm.kind) == (3.0, 4.0, 5.0, "plaza")
    square = as_landmark({"id": "S", "polygon": [[0, 0], [0, 2], [2, 2], [2, 0]]})
    assert (square.north, square.east, square.kind) == (1.0, 1.0, "landmark")
    with pytest.raises(ValueError, match="not a landmark"):
        as_landmark({"kind": "exit", "north": 1, "east": 2})


def _landmark_relations_by_brute_force(
    people: list[tuple[str, float, float]],
    vel: dict[str, tuple[float, float]],
    landmarks: list[LandmarkContract],
    cfg: RelationConfig,
) -> set[tuple[str, str, str | None, float | None]]:
    """inside / near / moving_toward from their definitions, each track against each landmark, no shortcut."""
    out: set[tuple[str, str, str | None, float | None]] = set()
    for ident, north, east in people:
        vn, ve = vel.get(ident, (0.0, 0.0))
        speed = float(np.hypot(vn, ve))
        moving = speed - 2.0 * 0.05 > cfg.moving_min_speed_mps  # the table's velocity sigma is 0.05
        for lm in landmarks:
            point = np.array([[north, east]])
            if lm.polygon is not None:
                poly = np.asarray(lm.polygon, dtype=float)
                inside = bool(points_in_polygon(point, poly)[0])
                dist = 0.0 if inside else float(distance_to_edge(point, poly)[0])
            else:
                d = float(np.hypot(north - lm.north, east - lm.east))
                inside = lm.radius_m is not None and d <= lm.radius_m
                dist = d if lm.radius_m is None else max(d - lm.radius_m, 0.0)
            if inside:
                out.add((ident, "inside", lm.id, None))
                continue
            if dist <= cfg.near_landmark_m:
                out.add((ident, "near", lm.id, round(dist, 2)))
            if moving and dist <= cfg.toward_max_m:
                bearing = np.array([lm.north - north, lm.east - east])
                cos = float(bearing @ np.array([vn, ve])) / max(float(np.hypot(*bearing)) * speed, 1e-9)
                if cos >= np.cos(np.radians(cfg.toward_angle_deg)):
                    out.add((ident, "moving_toward", lm.id, round(dist, 2)))
    return out


@pytest.mark.parametrize("seed", range(5))
def test_landmark_relations_skip_far_tracks_without_changing_any(seed: int) -> None:
    """The bounding-box shortcut (far tracks are not measured against a landmark) gives every relation the full
    computation gives: tracks placed at random, and exactly on, just inside and just beyond each reach."""
    rng = np.random.default_rng(seed)
    cfg = RelationConfig(near_landmark_m=float(rng.uniform(3, 15)), toward_max_m=float(rng.uniform(5, 60)))
    landmarks = [
        as_landmark({"id": "pt", "kind": "exit", "north": 0.0, "east": 0.0}),
        as_landmark({"id": "circ", "kind": "plaza", "north": 40.0, "east": -30.0, "radius_m": 12.0}),
        as_landmark({"id": "poly", "kind": "shade", "polygon": [[-50, 40], [-20, 55], [-35, 80], [-60, 70]]}),
    ]
    spots = rng.uniform(-140.0, 140.0, (400, 2))
    people = [(f"p{k}", float(n), float(e)) for k, (n, e) in enumerate(spots)]
    for k, reach in enumerate((cfg.near_landmark_m, cfg.toward_max_m)):  # on each reach from the point
        people += [(f"edge{k}{j}", reach + off, 0.0) for j, off in enumerate((-1e-6, 0.0, 1e-6))]
    vel = {ident: (float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2))) for ident, _, _ in people}
    vel = {ident: v for ident, v in vel.items() if rng.random() < 0.6}
    vel |= {f"edge1{j}": (-1.5, 0.0) for j in range(3)}  # heading for the point from its toward reach
    found = SceneGraph(cfg).update(table(people, vel=vel), landmarks=landmarks)
    got = {(r.subj, r.pred, r.obj, r.value) for r in found if r.obj in ("pt", "circ", "poly")}
    assert got == _landmark_relations_by_brute_force(people, vel, landmarks, cfg)
    assert {p for _, p, _, _ in got} == {"inside", "near", "moving_toward"}
