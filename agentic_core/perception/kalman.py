"""A constant-velocity Kalman filter on the ground plane, vectorised over every track at once.

State per track: ``[north, east, v_north, v_east]`` (m, m/s); measurement: ``[north, east]``. The process noise
is the continuous white-noise-acceleration model with spectral density ``q`` (m²/s³): a pedestrian's speed
wanders by about ``sqrt(q·t)`` m/s over ``t`` seconds. All functions take stacks (``x``: T×4, ``P``: T×4×4) so one
numpy call updates a thousand tracks; 2×2 innovation covariances are inverted in closed form.

>>> x, P = initial_state(np.array([[10.0, 5.0]]), np.array([np.eye(2) * 0.01]), speed_sigma=2.0)
>>> for k in range(1, 31):  # a target walking north at 1 m/s, seen at 30 Hz
...     x, P = predict(x, P, dt=1 / 30, q=0.5)
...     x, P = update(x, P, np.array([[10.0 + k / 30, 5.0]]), np.array([np.eye(2) * 0.01]))
>>> np.round(x[0], 1).tolist()
[11.0, 5.0, 1.0, 0.0]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


def transition(dt: float) -> FloatArray:
    """The 4×4 constant-velocity transition over ``dt`` seconds."""
    f = np.eye(4)
    f[0, 2] = f[1, 3] = dt
    return f


def process_noise(dt: float, q: float) -> FloatArray:
    """The 4×4 process noise of white acceleration with spectral density ``q`` over ``dt`` seconds."""
    a, b, c = q * dt**3 / 3.0, q * dt**2 / 2.0, q * dt
    return np.array([[a, 0.0, b, 0.0], [0.0, a, 0.0, b], [b, 0.0, c, 0.0], [0.0, b, 0.0, c]])


def initial_state(z: FloatArray, R: FloatArray, speed_sigma: float) -> tuple[FloatArray, FloatArray]:
    """Tracks born at measurements ``z`` (N×2, covariances ``R`` N×2×2), at rest with velocity std ``speed_sigma``."""
    n = len(z)
    x = np.zeros((n, 4))
    x[:, :2] = z
    P = np.zeros((n, 4, 4))
    P[:, :2, :2] = R
    P[:, 2, 2] = P[:, 3, 3] = speed_sigma**2
    return x, P


def predict(x: FloatArray, P: FloatArray, dt: float, q: float) -> tuple[FloatArray, FloatArray]:
    """Every track moved ``dt`` seconds ahead."""
    if dt <= 0.0 or len(x) == 0:
        return x.copy(), P.copy()
    f = transition(dt)
    x_new = x @ f.T
    P_new = f @ P @ f.T + process_noise(dt, q)
    return x_new, P_new


def inverse_2x2(S: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Inverses and determinants of a stack of symmetric positive-definite 2×2 matrices."""
    a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
    det = a * d - b * c
    inv = np.empty_like(S)
    inv[..., 0, 0] = d / det
    inv[..., 0, 1] = -b / det
    inv[..., 1, 0] = -c / det
    inv[..., 1, 1] = a / det
    return inv, det


def innovation(x: FloatArray, P: FloatArray, z: FloatArray, R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Residuals ``z - Hx`` (K×2) and their covariances ``HPHᵀ + R`` (K×2×2) for K track/measurement pairs."""
    return z - x[:, :2], P[:, :2, :2] + R


def mahalanobis_sq(nu: FloatArray, S: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Squared Mahalanobis distances of residuals ``nu`` under covariances ``S``, and ``log det S``."""
    inv, det = inverse_2x2(S)
    d2 = np.einsum("ki,kij,kj->k", nu, inv, nu)
    return d2, np.log(det)


def update(x: FloatArray, P: FloatArray, z: FloatArray, R: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The tracks ``x, P`` (K of them) corrected by one measurement each (``z`` K×2, ``R`` K×2×2)."""
    if len(x) == 0:
        return x.copy(), P.copy()
    nu, S = innovation(x, P, z, R)
    S_inv, _ = inverse_2x2(S)
    PHt = P[:, :, :2]  # P Hᵀ (K×4×2)
    K = PHt @ S_inv
    x_new = x + np.einsum("kij,kj->ki", K, nu)
    P_new = P - K @ np.swapaxes(PHt, 1, 2)  # P - K H P
    P_new = 0.5 * (P_new + np.swapaxes(P_new, 1, 2))
    return x_new, P_new


def speed_and_sigma(x: FloatArray, P: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Each track's estimated horizontal speed (m/s) and that estimate's standard deviation.

    The deviation is the velocity covariance projected on the direction of motion (its largest eigenvalue's
    root when the speed is near zero), so "clearly moving" is ``speed - k·sigma > threshold``.
    """
    v = x[:, 2:4]
    speed = np.hypot(v[:, 0], v[:, 1])
    Pv = P[:, 2:4, 2:4]
    a, b, d = Pv[:, 0, 0], Pv[:, 0, 1], Pv[:, 1, 1]
    largest = (a + d) / 2.0 + np.sqrt(((a - d) / 2.0) ** 2 + b * b)
    moving = speed > 1e-9
    safe = np.where(moving, speed, 1.0)
    u_n, u_e = v[:, 0] / safe, v[:, 1] / safe
    along = a * u_n * u_n + 2.0 * b * u_n * u_e + d * u_e * u_e
    sigma = np.sqrt(np.maximum(np.where(moving, along, largest), 0.0))
    return speed, sigma
