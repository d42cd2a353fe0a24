"""The constant-velocity Kalman filter: it smooths, it follows, and its covariance tells the truth."""

from __future__ import annotations

import numpy as np
import pytest

from agentic_core.perception import kalman

DT = 1 / 30


def filter_track(truth: np.ndarray, sigma: float, q: float, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run the filter on noisy measurements of a T×2 true path; returns states, covariances, measurements."""
    rng = np.random.default_rng(seed)
    z = truth + rng.normal(0, sigma, truth.shape)
    R = np.array([np.eye(2) * sigma**2])
    x, P = kalman.initial_state(z[:1], R, speed_sigma=1.5)
    xs, Ps = [x[0]], [P[0]]
    for k in range(1, len(truth)):
        x, P = kalman.predict(x, P, DT, q)
        x, P = kalman.update(x, P, z[k : k + 1], R)
        xs.append(x[0])
        Ps.append(P[0])
    return np.array(xs), np.array(Ps), z


@pytest.mark.parametrize("velocity", [(0.0, 0.0), (1.2, -0.4)])
def test_the_filter_beats_the_raw_measurements(velocity: tuple[float, float]) -> None:
    t = np.arange(300) * DT
    truth = np.column_stack([2.0 + velocity[0] * t, -1.0 + velocity[1] * t])
    sigma = 0.05
    xs, _, z = filter_track(truth, sigma, q=0.1, seed=1 + int(velocity[0] * 10))
    raw = np.sqrt(np.mean(np.sum((z[60:] - truth[60:]) ** 2, axis=1)))
    filtered = np.sqrt(np.mean(np.sum((xs[60:, :2] - truth[60:]) ** 2, axis=1)))
    v_err = np.abs(xs[60:, 2:] - velocity).max()
    print(f"\nvelocity {velocity}: raw RMSE {raw:.4f} m, filtered {filtered:.4f} m, worst velocity error {v_err:.3f}")
    assert filtered < 0.6 * raw  # the filter averages several frames
    assert v_err < 0.5


def test_a_turning_walker_is_followed() -> None:
    t = np.arange(300) * DT
    heading = 0.5 * t  # turning at 0.5 rad/s
    speed = 1.2
    truth = np.column_stack([np.cumsum(speed * np.cos(heading)) * DT, np.cumsum(speed * np.sin(heading)) * DT])
    xs, _, _ = filter_track(truth, 0.05, q=0.1, seed=2)
    err = np.hypot(*(xs[:, :2] - truth).T)
    print(f"\nturning walker: position error median {np.median(err):.3f} m, max {err[30:].max():.3f} m")
    assert err[30:].max() < 0.2


def test_the_covariance_is_consistent_with_the_errors() -> None:
    """Normalised estimation error squared over many runs averages the state dimension (4) on a CV target."""
    t = np.arange(120) * DT
    nees = []
    rng = np.random.default_rng(3)
    q = 0.1
    for seed in range(200):
        accel = rng.normal(0, np.sqrt(q / DT), (len(t), 2))  # white acceleration with density q
        v = np.array([1.0, 0.5]) + np.cumsum(accel, axis=0) * DT
        truth_pos = np.cumsum(v, axis=0) * DT
        xs, Ps, _ = filter_track(truth_pos, 0.05, q=q, seed=seed)
        err = np.concatenate([xs[-1, :2] - truth_pos[-1], xs[-1, 2:] - v[-1]])
        nees.append(err @ np.linalg.solve(Ps[-1], err))
    mean = float(np.mean(nees))
    print(f"\naverage NEES over 200 runs: {mean:.2f} (consistent: 4)")
    assert 3.0 < mean < 5.2  # 95 % band of a chi-square(4x200)/200 is about 3.6-4.4; room for discretisation


def test_inverse_and_mahalanobis() -> None:
    rng = np.random.default_rng(4)
    A = rng.normal(size=(50, 2, 2))
    S = A @ np.swapaxes(A, 1, 2) + np.eye(2) * 0.1
    inv, det = kalman.inverse_2x2(S)
    np.testing.assert_allclose(inv, np.linalg.inv(S), rtol=1e-9)
    np.testing.assert_allclose(det, np.linalg.det(S), rtol=1e-9)
    nu = rng.normal(size=(50, 2))
    d2, logdet = kalman.mahalanobis_sq(nu, S)
    np.testing.assert_allclose(d2, np.einsum("ki,kij,kj->k", nu, np.linalg.inv(S), nu), rtol=1e-9)
    np.testing.assert_allclose(logdet, np.log(np.linalg.det(S)), rtol=1e-9)


def test_empty_stacks_pass_through() -> None:
    x, P = np.empty((0, 4)), np.empty((0, 4, 4))
    for out in (kalman.predict(x, P, DT, 0.1), kalman.update(x, P, np.empty((0, 2)), np.empty((0, 2, 2)))):
        assert out[0].shape == (0, 4) and out[1].shape == (0, 4, 4)


def test_speed_sigma_is_along_the_motion() -> None:
    x = np.array([[0, 0, 3.0, 0.0], [0, 0, 0.0, 0.0]])
    P = np.zeros((2, 4, 4))
    P[:, 2, 2], P[:, 3, 3] = 0.04, 1.0  # north velocity well known, east poorly
    speed, sigma = kalman.speed_and_sigma(x, P)
    assert speed.tolist() == [3.0, 0.0]
    assert sigma[0] == pytest.approx(0.2) and sigma[1] == pytest.approx(1.0)
