"""The pipeline end to end: state across frames, geodesy, landmarks, what it publishes, its stage timings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agentic_core.contracts.geodesy import offset_position
from agentic_core.perception.pipeline import STAGES, Perception, PerceptionConfig
from flight.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame, project_points

from .synthetic import SyntheticScene, run

HOME = (21.4133, 39.8933, 300.0)


def test_objects_carry_lat_lon_consistent_with_their_north_east() -> None:
    perception = Perception(home=HOME)
    for frame, detections, _ in run(SyntheticScene(seed=7, walkers=4, still=4), 30):
        world = perception.update(frame, detections)
    assert world.objects
    for o in world.objects:
        lat, lon = offset_position(HOME[0], HOME[1], o.pose.north, o.pose.east)
        assert (o.pose.lat, o.pose.lon) == pytest.approx((lat, lon), abs=1e-9)
        assert o.pose.alt == pytest.approx(HOME[2])
        assert o.id.startswith("P-") and o.class_name == "person" and 0.0 <= o.conf <= 1.0
    assert world.ego_pose.alt == pytest.approx(HOME[2] + 30.0)
    assert world.timestamp == pytest.approx(29 / 30) and world.frame == 29
    assert set(perception.timings) == set(STAGES) and all(v >= 0 for v in perception.timings.values())


def test_landmarks_get_lat_lon_and_appear_in_the_contract() -> None:
    perception = Perception(home=HOME, landmarks=[{"id": "Exit-3", "kind": "exit", "north": 100.0, "east": 0.0}])
    world = perception.update(
        Frame(index=0, time_s=0.0, spec=CameraSpec(), pose=CameraPose(north_m=0, east_m=0, down_m=-30)), []
    )
    (exit3,) = world.landmarks
    assert exit3.lat == pytest.approx(offset_position(HOME[0], HOME[1], 100.0, 0.0)[0])
    assert exit3.lon == pytest.approx(HOME[1])


def test_tentative_tracks_only_on_request() -> None:
    spec, pose = CameraSpec(), CameraPose(north_m=0, east_m=0, down_m=-30)
    ((u, v),) = project_points(spec, pose, np.array([[2.0, 2.0, -0.85]]))[0]
    det = Detection(
        class_name="person", box=BoundingBox(x_min=u - 9, y_min=v - 9, x_max=u + 9, y_max=v + 9), confidence=0.7
    )
    frame = Frame(index=0, time_s=0.0, spec=spec, pose=pose)
    assert Perception(home=HOME).update(frame, [det]).objects == []
    shown = Perception(home=HOME, config=PerceptionConfig(publish_tentative=True)).update(frame, [det]).objects
    assert [(o.id, o.state, o.track_age_frames) for o in shown] == [("P-01", "tentative", 1)]


def test_a_person_who_leaves_the_view_is_lost_then_forgotten() -> None:
    spec = CameraSpec()
    perception = Perception(home=HOME)
    target = np.array([[0.0, 0.0, -0.85]])
    for k in range(200):
        pose = CameraPose(north_m=10.0 * k / 30, east_m=0.0, down_m=-30.0)  # flying north at 10 m/s
        pixels, visible = project_points(spec, pose, target)
        dets = []
        if visible[0]:
            u, v = pixels[0]
            dets = [
                Detection(
                    class_name="person",
                    box=BoundingBox(x_min=u - 9, y_min=v - 9, x_max=u + 9, y_max=v + 9),
                    confidence=0.8,
                )
            ]
        world = perception.update(Frame(index=k, time_s=k / 30, spec=spec, pose=pose), dets)
        if k == 20:
            assert [o.state for o in world.objects] == ["confirmed"]
        if visible[0]:
            last_visible = k
        elif k == last_visible + 1:
            assert [o.state for o in world.objects] == ["lost"]  # out of sight: lost at once, not coasting
    assert world.objects == []  # forgotten after the re-identification window
    assert math.isclose(perception.tracker.config.reid_window_s, 3.0)


def test_snapshot_before_any_frame_is_an_error() -> None:
    with pytest.raises(RuntimeError, match="no frame yet"):
        Perception(home=HOME).snapshot()


def test_the_scene_graph_follows_the_pipeline() -> None:
    perception = Perception(home=HOME, landmarks=[{"id": "Exit-3", "kind": "exit", "north": 3.0, "east": 0.0}])
    for frame, detections, _ in run(SyntheticScene(seed=8, walkers=3, still=3), 20):
        world = perception.update(frame, detections)
    graph = perception.scene_graph.graph
    assert graph.nodes["ego"]["down"] == -30.0 and graph.nodes["ego"]["time"] == world.timestamp
    assert {o.id for o in world.objects} <= set(graph.nodes)
    binary = {(r.subj, r.pred, r.obj) for r in world.relations if r.obj is not None}
    assert binary == {(u, k, v) for u, v, k in graph.edges(keys=True) if k != "observes"}
