"""The Kalman filter linearised: one joint's steady-state gain on the linear arm (for
the delay margin of the loop the filter is part of), and the running filter's
transition, the arm model's slopes carried over a period (:class:`Linearisation`,
a part of :class:`~robot_controller.core.estimation.estimator.JointKalmanFilter`)."""

from __future__ import annotations

import numpy as np

from robot_controller.core.arrays import matrix_power
from robot_controller.core.estimation.kalman_config import KalmanConfig, process_noise
from robot_controller.core.model import step_count

# Finite-difference steps for the model's slopes, rad and rad/s.
_BUMP_Q, _BUMP_V = 1e-6, 1e-5


def steady_state_gain(
    config: KalmanConfig, inertia: float, damping: float, period_s: float, estimate_disturbance: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One joint's filter at rest, linear (``inertia·q̈ + damping·q̇ = τ (+ d)``,
    gravity's stiffness left out as at the horizontal), readings every
    ``period_s``, in steady state: its transition ``F`` and torque input ``B``
    over the period (exact, zero-order hold) and the Kalman gain ``L``
    (``m × 2``, m = 2, or 3 with the disturbance observer). For the delay
    margin of the loop the filter is part of."""
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


class Linearisation:
    """The model's slopes of :class:`~robot_controller.core.estimation.estimator.JointKalmanFilter`:
    the covariance's prediction and the array update take them from here."""

    def _step_slopes(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
        """One model step's ∂[q'; v']/∂[q; v] (2n × 2n): the model's own, or by finite differences."""
        if self.jacobian is not None:
            return self.jacobian(q, v, torque, h)
        n = self.joint_count
        q1, v1 = self.predictor(q, v, torque, h, max_step_s=h)
        slopes = np.zeros((2 * n, 2 * n))
        for k in range(2 * n):
            bump = _BUMP_Q if k < n else _BUMP_V
            dq, dv = np.zeros(n), np.zeros(n)
            (dq if k < n else dv)[k % n] = bump
            q2, v2 = self.predictor(q + dq, v + dv, torque, h, max_step_s=h)
            slopes[:n, k], slopes[n:, k] = (q2 - q1) / bump, (v2 - v1) / bump
        return slopes

    def _transition(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, dt: float) -> np.ndarray:
        """The model linearised at ``(q, v)`` over ``dt`` (nm × nm, joint by joint): one
        model step's slopes carried over the period's steps, every joint's on every
        joint's, gravity's stiffness (destabilising on one side of the arm's travel)
        and the damping included; with only the double integrator, a filter that trusts
        the model (a small acceleration_noise_std) lets its error grow where gravity
        pulls the arm away. ``d`` moves its own joint as a torque there would."""
        n, m = self.joint_count, self.size
        g, k = self._groups, self._per_group
        steps = step_count(dt, self.config.model_step_s)
        h = dt / steps
        F = np.zeros((g, k * m, k * m))
        at = self._index
        if g == 1:
            F[0][at.model_slopes] = matrix_power(self._step_slopes(q, v, torque, h), steps)  # [q; v] by [q; v]
        else:
            F[:, :2, :2] = np.linalg.matrix_power(self._own_slopes(q, v, torque, h), steps)
        if self.estimates_disturbance:
            b = self._own_inverse_mass if self._inverse_mass is not None else np.zeros(n)
            F[:, at.q, at.d] = (0.5 * b * dt * dt).reshape(g, k)
            F[:, at.v, at.d] = (b * dt).reshape(g, k)
            F[:, at.d, at.d] = 1.0
        return F

    def _own_slopes(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
        """Independent joints: each one's step slopes ∂[q'; v']/∂[q; v] (n, 2, 2), every joint
        bumped at once (none moves another)."""
        q1, v1 = self.predictor(q, v, torque, h, max_step_s=h)
        q2, v2 = self.predictor(q + _BUMP_Q, v, torque, h, max_step_s=h)
        q3, v3 = self.predictor(q, v + _BUMP_V, torque, h, max_step_s=h)
        slopes = np.empty((self.joint_count, 2, 2))
        slopes[:, 0, 0], slopes[:, 1, 0] = (q2 - q1) / _BUMP_Q, (v2 - v1) / _BUMP_Q
        slopes[:, 0, 1], slopes[:, 1, 1] = (q3 - q1) / _BUMP_V, (v3 - v1) / _BUMP_V
        return slopes
