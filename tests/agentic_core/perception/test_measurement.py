"""Ground measurements and their covariances; degraded sensors raise the covariances perception reports."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.perception.measurement import (
    NoiseModel,
    common_covariance,
    ego_covariance,
    ground_measurements,
)
from agentic_core.perception.pipeline import Perception
from flight.camera import BoundingBox, CameraPose, CameraSpec, Detection, Frame, SensorHealth, project_points

from .synthetic import SyntheticScene, run

POSE = CameraPose(north_m=0.0, east_m=0.0, down_m=-30.0)
HOME = (21.4133, 39.8933, 300.0)


def det(u: float, v: float, half: float = 15.0, cls: str = "person") -> Detection:
    return Detection(
        class_name=cls, box=BoundingBox(x_min=u - half, y_min=v - half, x_max=u + half, y_max=v + half), confidence=0.9
    )


def frame(health: SensorHealth | None = None, spec: CameraSpec | None = None) -> Frame:
    return Frame(index=0, time_s=0.0, spec=spec or CameraSpec(), pose=POSE, health=health or SensorHealth())


def test_box_centres_land_on_the_ground_under_the_body() -> None:
    spec = CameraSpec()
    bodies = np.array([[10.0, -5.0, -0.85], [-12.0, 20.0, -0.85]])  # people's middles, 0.85 m up
    pixels, _ = project_points(spec, POSE, bodies)
    m = ground_measurements(frame(), [det(u, v) for u, v in pixels], NoiseModel())
    np.testing.assert_allclose(m.z, bodies[:, :2], atol=1e-9)
    ground = ground_measurements(frame(), [det(u, v) for u, v in pixels], NoiseModel(centre_height_m={}))
    assert np.all(np.hypot(*(ground.z - bodies[:, :2]).T) > 0.2)  # cast on the ground: pushed away from the nadir


@pytest.mark.parametrize("sensor", ["camera", "thermal", "imu"])
def test_degraded_image_sensors_raise_the_measurement_covariance(sensor: str) -> None:
    healthy = ground_measurements(frame(), [det(700, 400)], NoiseModel())
    degraded = ground_measurements(frame(SensorHealth(degraded={sensor: 3.0})), [det(700, 400)], NoiseModel())
    ratio = np.trace(degraded.R[0]) / np.trace(healthy.R[0])
    assert ratio > 2.0, ratio


def test_a_degraded_fix_raises_the_ego_and_object_covariance() -> None:
    noise = NoiseModel()
    gps = SensorHealth(degraded={"gps": 4.0})
    assert np.trace(ego_covariance(noise, gps)) > 10 * np.trace(ego_covariance(noise, SensorHealth()))
    point = np.array([[10.0, 5.0]])
    assert np.trace(common_covariance(noise, gps, POSE, point)[0]) > 10 * np.trace(
        common_covariance(noise, SensorHealth(), POSE, point)[0]
    )
    jitter = ground_measurements(frame(gps), [det(700, 400)], noise).R[0]
    assert np.trace(jitter) > np.trace(ground_measurements(frame(), [det(700, 400)], noise).R[0])


def test_covariance_grows_with_the_offset_from_the_nadir_along_it() -> None:
    cov = common_covariance(NoiseModel(), SensorHealth(), POSE, np.array([[0.0, 0.0], [0.0, 20.0]]))
    assert cov[1, 1, 1] > cov[0, 1, 1] and cov[1, 0, 0] == pytest.approx(cov[0, 0, 0])


def test_a_box_cut_by_the_image_edge_is_uncertain_across_that_edge() -> None:
    inside = ground_measurements(frame(), [det(960, 300)], NoiseModel()).R[0]
    cut = ground_measurements(frame(), [det(960, 10)], NoiseModel()).R[0]  # its top edge at the image's top
    # image up is north for the nadir camera facing north: the cut axis is north, east unaffected
    assert cut[0, 0] > 20 * inside[0, 0]
    assert cut[1, 1] == pytest.approx(inside[1, 1], rel=0.05)


def test_an_oblique_view_stretches_the_covariance_in_range() -> None:
    spec = CameraSpec(gimbal_pitch_deg=-30.0)
    m = ground_measurements(frame(spec=spec), [det(960, 540)], NoiseModel())
    assert m.R[0, 0, 0] > 3 * m.R[0, 1, 1]  # looking north: range (north) error ≫ cross-range (east)


def test_rays_above_the_horizon_are_dropped() -> None:
    spec = CameraSpec(gimbal_pitch_deg=0.0)
    m = ground_measurements(frame(spec=spec), [det(960, 100), det(960, 1000)], NoiseModel())
    assert m.index.tolist() == [1]


def test_degraded_sensors_raise_the_reported_object_covariance_end_to_end() -> None:
    results = {}
    for name, health in (
        ("healthy", SensorHealth()),
        ("camera", SensorHealth(degraded={"camera": 3.0})),
        ("gps", SensorHealth(degraded={"gps": 4.0})),
    ):
        perception = Perception(home=HOME)
        for f, detections, _ in run(SyntheticScene(seed=6, walkers=5, still=5, health=health), 60):
            world = perception.update(f, detections)
        assert world.health.degraded_sensors == sorted(health.degraded)
        tracks = perception.tracks
        assert tracks is not None
        results[name] = (
            float(np.median([np.trace(np.array(o.cov)) for o in world.objects])),
            float(np.trace(np.array(world.ego_pose.cov))),
            float(np.median(np.trace(tracks.P[:, :2, :2], axis1=1, axis2=2))),
        )
    print("\nmedian trace (m²) of: object cov (reported), ego cov, tracker position cov")
    for name, values in results.items():
        print(f"  {name:8} " + "  ".join(f"{v:.5f}" for v in values))
    # a poor camera: the tracker is less sure of where people are (the reported cov, dominated by the absolute
    # position of the aircraft, grows by that little); a poor fix: everything absolute is less sure
    assert results["camera"][2] > 2 * results["healthy"][2] and results["camera"][0] > results["healthy"][0]
    assert results["gps"][0] > 4 * results["healthy"][0] and results["gps"][1] > 4 * results["healthy"][1]
