"""The camera's pinhole geometry: projection and back-projection agree, and the footprint has the size optics say."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydantic import ValidationError

from flight.camera import (
    BoundingBox,
    CameraPose,
    CameraSpec,
    Detection,
    Detector,
    Frame,
    SensorHealth,
    footprint,
    ground_points,
    ground_sample_distance,
    pose_of,
    project_points,
    rotation_world_from_camera,
)
from flight.sim import Simulator

SPEC = CameraSpec()


def ground_grid(n: int = 25, half_m: float = 20.0) -> np.ndarray:
    north, east = np.meshgrid(np.linspace(-half_m, half_m, n), np.linspace(-half_m, half_m, n))
    return np.column_stack([north.ravel(), east.ravel(), np.zeros(n * n)])


@pytest.mark.parametrize(
    "pose",
    [
        CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0),
        CameraPose(north_m=12.0, east_m=-7.0, down_m=-45.0, yaw_rad=1.1),
        CameraPose(north_m=-3.0, east_m=5.0, down_m=-20.0, roll_rad=0.2, pitch_rad=-0.15, yaw_rad=-2.5),
    ],
)
def test_pixels_cast_back_to_the_ground_points_they_came_from(pose: CameraPose) -> None:
    points = ground_grid() + np.array([pose.north_m, pose.east_m, 0.0])
    pixels, visible = project_points(SPEC, pose, points)
    assert visible.sum() > 100
    ground, hits = ground_points(SPEC, pose, pixels[visible])
    assert hits.all()
    np.testing.assert_allclose(ground, points[visible, :2], atol=1e-9)


def test_nadir_image_has_north_up_and_east_right() -> None:
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    pixels, _ = project_points(SPEC, pose, np.array([[5.0, 0.0, 0.0], [0.0, 5.0, 0.0]]))
    cx, cy = SPEC.principal_point
    assert pixels[0, 1] < cy and pixels[0, 0] == pytest.approx(cx)  # north is up the image
    assert pixels[1, 0] > cx and pixels[1, 1] == pytest.approx(cy)  # east is right


def test_heading_turns_the_image() -> None:
    """Facing east, a point to the east is at the top of the image."""
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0, yaw_rad=math.pi / 2)
    pixels, _ = project_points(SPEC, pose, np.array([[0.0, 5.0, 0.0]]))
    assert pixels[0, 0] == pytest.approx(SPEC.principal_point[0], abs=1e-9)
    assert pixels[0, 1] < SPEC.principal_point[1]


def test_stabilised_gimbal_ignores_roll_and_pitch_and_a_fixed_one_does_not() -> None:
    level = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    tilted = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0, roll_rad=0.3, pitch_rad=0.2)
    np.testing.assert_allclose(rotation_world_from_camera(SPEC, level), rotation_world_from_camera(SPEC, tilted))
    fixed = SPEC.model_copy(update={"stabilized": False})
    rolled = rotation_world_from_camera(fixed, tilted)
    assert not np.allclose(rolled, rotation_world_from_camera(fixed, level))
    np.testing.assert_allclose(rolled @ rolled.T, np.eye(3), atol=1e-12)  # still a rotation


def test_footprint_matches_the_field_of_view() -> None:
    altitude = 30.0
    corners = footprint(SPEC, CameraPose(north_m=0.0, east_m=0.0, down_m=-altitude))
    assert corners is not None
    width = corners[:, 1].max() - corners[:, 1].min()
    height = corners[:, 0].max() - corners[:, 0].min()
    assert width == pytest.approx(2 * altitude * math.tan(math.radians(SPEC.hfov_deg) / 2))
    assert height == pytest.approx(2 * altitude * math.tan(math.radians(SPEC.vfov_deg) / 2))
    assert width / height == pytest.approx(SPEC.width_px / SPEC.height_px)


def test_a_camera_looking_at_the_horizon_has_no_footprint_and_sky_pixels_miss_the_ground() -> None:
    forward = SPEC.model_copy(update={"gimbal_pitch_deg": 0.0})
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    assert footprint(forward, pose) is None
    ground, hits = ground_points(forward, pose, np.array([[960.0, 100.0], [960.0, 1000.0]]))
    assert not hits[0] and np.isnan(ground[0]).all()  # above the horizon
    assert hits[1] and ground[1, 0] > 0  # below it, ahead of the aircraft


def test_points_behind_the_camera_are_not_visible() -> None:
    forward = SPEC.model_copy(update={"gimbal_pitch_deg": 0.0})
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    pixels, visible = project_points(forward, pose, np.array([[-50.0, 0.0, -30.0]]))
    assert not visible[0] and np.isnan(pixels[0]).all()


def test_ground_sample_distance_grows_with_range() -> None:
    pose = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
    gsd = ground_sample_distance(SPEC, pose, [[0.0, 0.0, 0.0], [0.0, 0.0, -15.0]])
    assert gsd[0] == pytest.approx(30.0 / SPEC.focal_px)
    assert gsd[1] == pytest.approx(gsd[0] / 2)


def test_pose_from_a_simulated_vehicle() -> None:
    state = Simulator(seed=1).state()
    pose = pose_of(state)
    assert (pose.north_m, pose.east_m, pose.down_m, pose.yaw_rad) == (
        state.north_m,
        state.east_m,
        state.down_m,
        state.yaw_rad,
    )


def test_contract_models_refuse_nonsense() -> None:
    with pytest.raises(ValidationError, match="out of order"):
        BoundingBox(x_min=10, y_min=0, x_max=5, y_max=4)
    with pytest.raises(ValidationError, match="confidence"):
        Detection.model_validate(
            {"class": "person", "box": BoundingBox(x_min=0, y_min=0, x_max=1, y_max=1), "confidence": 1.5}
        )
    with pytest.raises(ValidationError, match="must be >= 1: gps"):
        SensorHealth(degraded={"gps": 0.5})
    health = SensorHealth(degraded={"thermal": 3.0})
    assert health.factor("thermal") == 3.0 and health.factor("gps") == 1.0 and not health.ok


def test_detection_reads_and_writes_the_class_field_by_its_json_name() -> None:
    box = BoundingBox(x_min=0, y_min=0, x_max=4, y_max=8)
    detection = Detection.model_validate({"class": "person", "box": box.model_dump(), "confidence": 0.7})
    assert detection.class_name == "person" and box.center == (2.0, 4.0)
    assert detection.model_dump(by_alias=True)["class"] == "person"


def test_anything_with_a_detect_method_is_a_detector() -> None:
    class Nothing:
        def detect(self, frame: Frame) -> list[Detection]:
            return []

    frame = Frame(index=0, time_s=0.0, spec=SPEC, pose=CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0))
    assert isinstance(Nothing(), Detector) and Nothing().detect(frame) == []
