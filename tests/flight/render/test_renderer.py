"""The rendered camera: deterministic by seed, people where the pinhole model puts them, poses told apart by their
boxes, and a valid picture for every hostile view (sky, the ground itself, nobody, nobody in view, bare ground)."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.contracts.camera import CameraPose, CameraSpec
from agentic_core.contracts.pinhole import project_points
from flight.sim.render import SceneRenderer
from flight.sim.scene_file import load_scene
from flight.sim.scene_model import NE, Actor, GroundTruth, Scene, Zone

SMALL = CameraSpec(width_px=160, height_px=120)


def _one(behaviour: str, north: float = 0.0, east: float = 0.0, heading: float = 0.0) -> Scene:
    h = np.radians(heading)
    velocity = NE(north=float(np.cos(h)), east=float(np.sin(h))) if behaviour == "walking" else NE(north=0, east=0)
    actor = Actor.model_validate(
        {"id": "P-1", "behaviour": behaviour, "position": NE(north=north, east=east), "heading_deg": heading,
         "velocity": velocity}
    )  # fmt: skip
    casualties = ["P-1"] if behaviour == "collapsed" else []
    truth = GroundTruth(expected_severity="high" if casualties else "none", casualties=casualties)
    return Scene(id="one", seed=5, actors=[actor], ground_truth=truth)


def _valid(image: np.ndarray, spec: CameraSpec) -> None:
    assert image.shape == (spec.height_px, spec.width_px, 3)
    assert image.dtype == np.uint8


def test_same_seed_same_frame_other_seed_other_noise() -> None:
    scene = load_scene("scenes/hajj_emergency.yaml")
    pose = CameraPose(north_m=150.0, east_m=0.0, down_m=-30.0, yaw_rad=0.4)
    first = SceneRenderer(scene, seed=3).render(SMALL, pose, frame_index=2)
    again = SceneRenderer(scene, seed=3).render(SMALL, pose, frame_index=2)
    other = SceneRenderer(scene, seed=4).render(SMALL, pose, frame_index=2)
    assert np.array_equal(first.image, again.image)
    assert first.persons.ids == again.persons.ids and np.array_equal(first.persons.boxes, again.persons.boxes)
    assert not np.array_equal(first.image, other.image)
    assert len(first.persons.ids) > 20  # the road's crowd is in view


def test_lying_person_is_drawn_where_the_pinhole_projects_them() -> None:
    spec = CameraSpec(width_px=640, height_px=480)
    pose = CameraPose(north_m=-4.0, east_m=2.0, down_m=-30.0, yaw_rad=0.7)
    renderer = SceneRenderer(_one("collapsed", north=5.0, east=-3.0, heading=30.0), seed=1)
    out = renderer.render(spec, pose)
    assert out.persons.ids == ["P-1"] and out.persons.poses == ("lying",)
    ((x, y),) = project_points(spec, pose, np.array([[5.0, -3.0, 0.0]]))[0]
    x0, y0, x1, y1 = out.persons.boxes[0]
    assert x0 <= x <= x1 and y0 <= y <= y1
    background = SceneRenderer(Scene(id="empty", seed=5), seed=1).render(spec, pose).image
    inside = out.image[int(y0) : int(y1) + 1, int(x0) : int(x1) + 1].astype(int)
    outside = background[int(y0) : int(y1) + 1, int(x0) : int(x1) + 1].astype(int)
    assert np.abs(inside - outside).sum(axis=2).max() > 60  # something is really drawn there


@pytest.mark.parametrize("heading", [0.0, 90.0])
def test_poses_differ_in_box_shape_at_nadir(heading: float) -> None:
    spec = CameraSpec(width_px=320, height_px=240)
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-20.0)
    sizes = {}
    for behaviour, name in (("collapsed", "lying"), ("standing", "standing"), ("sitting", "sitting"),
                            ("walking", "walking")):  # fmt: skip
        out = SceneRenderer(_one(behaviour, heading=heading), seed=2).render(spec, pose)
        assert out.persons.poses == (name,)
        x0, y0, x1, y1 = out.persons.boxes[0]
        sizes[name] = (max(x1 - x0, y1 - y0), min(x1 - x0, y1 - y0))
    long, short = sizes["lying"]
    assert long / short > 2.0  # lying: long and thin
    assert sizes["standing"][0] < 0.5 * long  # standing, from straight above: small and round
    assert sizes["standing"][0] / sizes["standing"][1] < 1.5
    assert sizes["standing"][0] < sizes["sitting"][0] < long
    assert sizes["walking"][0] > sizes["standing"][0]  # legs in stride


@pytest.mark.parametrize(
    ("spec", "pose"),
    [
        (CameraSpec(width_px=160, height_px=120, gimbal_pitch_deg=0.0), CameraPose(north_m=0, east_m=0, down_m=-30)),
        (CameraSpec(width_px=160, height_px=120, gimbal_pitch_deg=30.0), CameraPose(north_m=0, east_m=0, down_m=-2)),
        (SMALL, CameraPose(north_m=150.0, east_m=14.0, down_m=0.0)),
        (SMALL, CameraPose(north_m=150.0, east_m=14.0, down_m=5.0)),
        (
            CameraSpec(width_px=160, height_px=120, gimbal_pitch_deg=-45.0),
            CameraPose(north_m=0, east_m=-15, down_m=-0.5),
        ),
    ],
    ids=["horizon", "sky", "altitude-0", "underground", "low-oblique"],
)
def test_hostile_views_give_a_valid_picture(spec: CameraSpec, pose: CameraPose) -> None:
    out = SceneRenderer(load_scene("scenes/hajj_emergency.yaml"), seed=1).render(spec, pose)
    _valid(out.image, spec)
    assert np.isfinite(out.persons.boxes).all()
    boxes = out.persons.boxes
    assert ((boxes[:, 0] >= 0) & (boxes[:, 2] <= spec.width_px) & (boxes[:, 1] >= 0)).all()
    if spec.gimbal_pitch_deg >= 0:
        assert out.image[0].std(axis=0).max() < 8  # the top row is sky: one smooth colour


def test_nobody_no_zones_and_nobody_in_view() -> None:
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-40.0)
    empty = SceneRenderer(Scene(id="bare", seed=1), seed=1).render(SMALL, pose)
    _valid(empty.image, SMALL)
    assert empty.persons.ids == [] and empty.persons.boxes.shape == (0, 4)
    away = SceneRenderer(_one("standing", north=500.0), seed=1).render(SMALL, pose)
    assert away.persons.ids == []
    assert empty.image.std() > 2  # textured ground, not a flat fill
    crowd = Scene(
        id="crowd",
        seed=2,
        zones=[Zone(id="Z", circle={"center": {"north": 900, "east": 0}, "radius_m": 20}, density=1.0)],
    )
    assert SceneRenderer(crowd, seed=1).render(SMALL, pose).persons.ids == []


def test_motion_blur_smooths_the_picture() -> None:
    scene = load_scene("scenes/hajj_emergency.yaml")
    pose = CameraPose(north_m=150.0, east_m=-10.0, down_m=-12.0)
    still = SceneRenderer(scene, seed=1).render(SMALL, pose, velocity_ned=(0.0, 0.0, 0.0)).image.astype(float)
    fast = SceneRenderer(scene, seed=1).render(SMALL, pose, velocity_ned=(0.0, 60.0, 0.0)).image.astype(float)
    assert np.abs(np.diff(fast, axis=1)).mean() < 0.8 * np.abs(np.diff(still, axis=1)).mean()


def test_rendering_camera_fills_frames_and_blurs_with_the_vehicles_velocity() -> None:
    from flight.sim.render.camera import RenderingCamera, render_spec, rendering_camera
    from flight.sim.scene import SceneState

    state = SceneState(load_scene("scenes/hajj_emergency.yaml"))
    camera = rendering_camera(state, seed=2)
    frame = camera.capture(CameraPose(north_m=150.0, east_m=0.0, down_m=-30.0), time_s=0.5)
    assert isinstance(camera, RenderingCamera) and frame.spec == render_spec()
    assert frame.image is not None and frame.image.shape == (480, 640, 3) and state.time_s == 0.5
    assert "image" not in frame.model_dump()  # pixels stay out of the JSON form
