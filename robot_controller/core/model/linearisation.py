"""A model known only by its ``predict`` linearised by finite differences: one step's slopes
∂[q'; v']/∂[q; v], carried over a horizon's steps (what :meth:`ArmDynamics.transition` gives from
MuJoCo's own differences). The Kalman filter uses it for such a model (the diagonal arm model, a
batch of independent joints)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.model.arm_dynamics import matrix_power, step_count

# (q, v, torque, horizon_s, max_step_s=, external_nm=) → predicted (q, v): an arm model's ``predict``
Predictor = Callable[..., tuple[np.ndarray, np.ndarray]]
# (q, v, torque, horizon_s, max_step_s) → ∂[q(T); v(T)]/∂[q; v]: (2n, 2n), or (n, 2, 2) for independent joints
Transition = Callable[[np.ndarray, np.ndarray, np.ndarray, float, float], np.ndarray]

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


def transition_by_differences(predictor: Predictor, independent_joints: bool) -> Transition:
    """``predictor``'s transition over a horizon, from one step's slopes by finite differences."""

    def transition(q: np.ndarray, v: np.ndarray, torque: np.ndarray, horizon_s: float, max_step_s: float):
        steps = step_count(horizon_s, max_step_s)
        h = horizon_s / steps
        if independent_joints:
            return np.linalg.matrix_power(own_step_slopes(predictor, q, v, torque, h), steps)
        return matrix_power(step_slopes(predictor, q, v, torque, h), steps)

    return transition
