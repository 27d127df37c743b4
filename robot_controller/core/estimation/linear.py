"""One joint's Kalman filter at rest on the linear arm, in steady state (for the delay margin of the
loop the filter is part of)."""

from __future__ import annotations

import numpy as np

from robot_controller.core.estimation.config import KalmanConfig
from robot_controller.core.estimation.process_noise import process_noise


def steady_state_gain(
    config: KalmanConfig, inertia: float, damping: float, period_s: float, estimate_disturbance: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One joint's filter at rest on ``inertia·q̈ + damping·q̇ = τ (+ d)`` in steady state: its transition ``F``
    and torque input ``B`` over ``period_s`` (zero-order hold) and the Kalman gain ``L`` (m × 2; m = 3 with the
    observer)."""
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
