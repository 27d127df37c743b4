"""The Kalman filter linearised: the arm model's slopes over one step by finite differences
(for a model without its own Jacobian) and carried over several (:func:`matrix_power`), and one
joint's steady-state gain on the linear arm (for the delay margin of the loop the filter is part of)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.estimation.config import KalmanConfig, process_noise

# (q, v, torque, horizon_s, max_step_s=, external_nm=) → predicted (q, v): the arm model's ``predict``
Predictor = Callable[..., tuple[np.ndarray, np.ndarray]]

# Finite-difference steps for the model's slopes, rad and rad/s.
_BUMP_Q, _BUMP_V = 1e-6, 1e-5


def step_slopes(predictor: Predictor, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
    """One model step's (``h`` s) ∂[q'; v']/∂[q; v] (2n × 2n), every joint bumped in turn."""
    n = q.size
    q1, v1 = predictor(q, v, torque, h, max_step_s=h)
    slopes = np.zeros((2 * n, 2 * n))
    for k in range(2 * n):
        bump = _BUMP_Q if k < n else _BUMP_V
        dq, dv = np.zeros(n), np.zeros(n)
        (dq if k < n else dv)[k % n] = bump
        q2, v2 = predictor(q + dq, v + dv, torque, h, max_step_s=h)
        slopes[:n, k], slopes[n:, k] = (q2 - q1) / bump, (v2 - v1) / bump
    return slopes


def matrix_power(a: np.ndarray, k: int) -> np.ndarray:
    """``np.linalg.matrix_power(a, k)`` for a square ``a`` and ``k >= 1``: the same products in the
    same order (binary powering), by ``ndarray.dot``, without its checks and dispatch."""
    if k == 3:
        return a.dot(a).dot(a)
    power = result = None
    while k > 0:
        power = a if power is None else power.dot(power)
        k, bit = divmod(k, 2)
        if bit:
            result = power if result is None else result.dot(power)
    return result


def own_step_slopes(predictor: Predictor, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
    """Independent joints: each one's step (``h`` s) slopes ∂[q'; v']/∂[q; v] (n, 2, 2), every
    joint bumped at once (none moves another)."""
    q1, v1 = predictor(q, v, torque, h, max_step_s=h)
    q2, v2 = predictor(q + _BUMP_Q, v, torque, h, max_step_s=h)
    q3, v3 = predictor(q, v + _BUMP_V, torque, h, max_step_s=h)
    slopes = np.empty((q.size, 2, 2))
    slopes[:, 0, 0], slopes[:, 1, 0] = (q2 - q1) / _BUMP_Q, (v2 - v1) / _BUMP_Q
    slopes[:, 0, 1], slopes[:, 1, 1] = (q3 - q1) / _BUMP_V, (v3 - v1) / _BUMP_V
    return slopes


def steady_state_gain(
    config: KalmanConfig, inertia: float, damping: float, period_s: float, estimate_disturbance: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One joint's filter at rest on the linear arm (``inertia·q̈ + damping·q̇ = τ (+ d)``, no
    gravity), in steady state: its transition ``F`` and torque input ``B`` over the period
    (zero-order hold) and the Kalman gain ``L`` (m × 2; m = 3 with the observer).

    :param inertia: kg·m²
    :param damping: N·m·s/rad
    :param period_s: the readings' period, s
    """
    from scipy.linalg import solve_discrete_are

    from robot_controller.core.laws.lqr import discretise  # [∫e, e, ė]: its lower block is [q, v]

    A3, B3 = discretise(float(inertia), float(damping), float(period_s))
    m = 3 if estimate_disturbance else 2
    F = np.eye(m)
    F[:2, :2] = A3[1:, 1:]
    B = np.zeros((m, 1))
    B[:2] = B3[1:]
    if estimate_disturbance:
        F[:2, 2:] = B3[1:]  # d acts as the actuator's torque does
        Q = process_noise(config, period_s, np.array([1.0 / inertia]))[0]
    else:
        Q = process_noise(config, period_s)
    H = np.eye(2, m)
    R = np.diag([config.position_noise_std**2, config.velocity_noise_std**2])
    P = solve_discrete_are(F.T, H.T, Q, R)  # the predicted covariance
    L = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    return F, B, L
