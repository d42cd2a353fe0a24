"""The fleet's scene graph: two UAVs' views of one person become one object, fused by covariance intersection,
whose uncertainty stays honest when the two views share an error; different people, classes or one UAV's own
objects never merge."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.contracts.errors import InputError
from agentic_core.contracts.geodesy import local_offset, offset_position
from agentic_core.contracts.world_model import WorldModel
from agentic_core.swarm.fusion import covariance_intersection, fuse

HOME = (21.4133, 39.8933)


def _view(t: float, *objects: tuple[str, str, float, float, tuple[float, float]]) -> WorldModel:
    def pose(north: float, east: float, down: float = 0.0) -> dict[str, float]:
        lat, lon = offset_position(*HOME, north, east)
        return {"north": north, "east": east, "down": down, "lat": lat, "lon": lon, "alt": -down}

    return WorldModel.model_validate(
        {
            "timestamp": t,
            "ego_pose": pose(0, 0, -30),
            "objects": [
                {"id": i, "class": c, "conf": 0.8, "pose": pose(n, e), "cov": ((vn, 0.0), (0.0, ve)), "last_seen": t}
                for i, c, n, e, (vn, ve) in objects
            ],
        }
    )


def test_two_views_of_one_person_fuse_into_one_object_seen_by_both() -> None:
    view = fuse(
        {
            "uav-1": _view(10.0, ("P-1", "person", 100.0, 50.0, (1.0, 9.0))),
            "uav-2": _view(11.0, ("P-7", "person", 101.0, 51.0, (9.0, 1.0))),
        }
    )
    assert [o.id for o in view.world.objects] == ["uav-1/P-1"]
    fused = view.world.objects[0]
    assert view.seen_by("uav-1/P-1") == {"uav-1", "uav-2"} and view.verified("uav-1/P-1", k=2)
    assert view.fleet_id("uav-2", "P-7") == "uav-1/P-1"
    assert 100.0 < fused.pose.north < 101.0 and 50.0 < fused.pose.east < 51.0
    assert np.trace(np.array(fused.cov)) < 10.0  # better than either view alone
    assert fused.conf == pytest.approx(1 - 0.2 * 0.2) and fused.last_seen == 11.0 and view.world.timestamp == 11.0
    north, east = local_offset(*HOME, fused.pose.lat, fused.pose.lon)
    # home is recovered from an object's two frames: the tangent plane's error, about a centimetre at 100 m
    assert north == pytest.approx(fused.pose.north, abs=0.05) and east == pytest.approx(fused.pose.east, abs=0.05)


def test_different_people_classes_and_one_uavs_own_objects_do_not_merge() -> None:
    view = fuse(
        {
            "uav-1": _view(1.0, ("P-1", "person", 0.0, 0.0, (1.0, 1.0)), ("P-2", "person", 0.5, 0.0, (1.0, 1.0))),
            "uav-2": _view(
                1.0,
                ("P-1", "person", 0.2, 0.0, (1.0, 1.0)),
                ("V-1", "vehicle", 0.5, 0.0, (1.0, 1.0)),
                ("P-3", "person", 60.0, 0.0, (1.0, 1.0)),
            ),
        }
    )
    ids = sorted(o.id for o in view.world.objects)
    assert ids == ["uav-1/P-1", "uav-1/P-2", "uav-2/P-3", "uav-2/V-1"]  # uav-2's P-1 joined exactly one of them
    assert sum(len(view.seen_by(i)) for i in ids) == 5 and not view.verified("uav-2/P-3", k=2)


def test_covariance_intersection_stays_honest_where_the_naive_product_is_overconfident() -> None:
    rng = np.random.default_rng(7)
    cov_a, cov_b = np.diag([4.0, 1.0]), np.diag([1.0, 4.0])
    shared = np.diag([3.0, 3.0])  # both UAVs inherit one map error: their estimates are correlated
    truth = np.zeros(2)
    ci_nees, naive_nees = [], []
    for _ in range(800):
        common = rng.multivariate_normal(truth, shared)
        a = common + rng.multivariate_normal(truth, cov_a)
        b = common + rng.multivariate_normal(truth, cov_b)
        mean, cov, _ = covariance_intersection(a, cov_a + shared, b, cov_b + shared)
        naive_cov = np.linalg.inv(np.linalg.inv(cov_a + shared) + np.linalg.inv(cov_b + shared))
        naive = naive_cov @ (np.linalg.solve(cov_a + shared, a) + np.linalg.solve(cov_b + shared, b))
        ci_nees.append(float(mean @ np.linalg.solve(cov, mean)))
        naive_nees.append(float(naive @ np.linalg.solve(naive_cov, naive)))
    assert np.mean(ci_nees) <= 2.0 * 1.05  # consistent: its errors are no larger than its covariance says
    assert np.mean(naive_nees) > 2.0 * 1.2  # the product that assumes independence claims too much


def test_fusing_nothing_is_a_clear_error() -> None:
    with pytest.raises(InputError, match="no World Model"):
        fuse({})
