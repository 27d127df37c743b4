"""State estimation: a Kalman filter on joint position and velocity, with
the applied torque as input, so the controller acts on a cleaner state than
the raw encoder reading.

Per joint, the state is ``x = [q, v]``. The prediction integrates the arm
model (MuJoCo forward dynamics, or the analytic arm) over the control period
under the torque commanded last, in steps no longer than the plant's own
(``model_step_s``); its covariance uses the model linearised about the
filtered state (gravity's stiffness, the damping) with white acceleration
noise, which is what the torque input leaves uncertain. Joints are filtered
independently (the reference arm has one).

The model, like the simulated plant (MuJoCo's default integrator), steps
semi-implicitly: each step's velocity is the one the position moves by over
that step. A velocity state, read or filtered, is therefore the arm's
velocity half a step before its position's instant;
:meth:`JointKalmanFilter.velocity_at_instant` gives the one at the instant.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError

# Finite-difference steps for the model's slopes, rad and rad/s.
_BUMP_Q, _BUMP_V = 1e-6, 1e-5

# (q, v, torque, dt) → predicted (q, v)
Predictor = Callable[[np.ndarray, np.ndarray, np.ndarray, float], tuple[np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class KalmanConfig:
    """:param position_noise_std: measurement σ on position, rad
    :param velocity_noise_std: measurement σ on velocity, rad/s
    :param acceleration_noise_std: σ of the unmodelled acceleration, rad/s²
    """

    position_noise_std: float = 0.005
    velocity_noise_std: float = 0.02
    acceleration_noise_std: float = 2.0
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (the simulator's physics step, 1 ms in the reference scenario), so that the prediction and
    #: the readings agree (a coarser step puts the predicted position off by about a·T·step/2)
    model_step_s: float = 0.001

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "velocity_noise_std", "acceleration_noise_std", "model_step_s"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")


class JointKalmanFilter:
    """Predict with the arm model, correct with each reading."""

    def __init__(self, config: KalmanConfig, joint_count: int, predictor: Predictor) -> None:
        self.config = config
        self.predictor = predictor
        self.joint_count = joint_count
        self.x: np.ndarray | None = None  # (n, 2): q, v per joint
        self.P = np.zeros((joint_count, 2, 2))
        self.R = np.diag([config.position_noise_std ** 2, config.velocity_noise_std ** 2])
        self.time_s: float | None = None

    def reset(self) -> None:
        self.x = None
        self.time_s = None

    def update(self, time_s: float, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Take a reading stamped ``time_s``; ``torque`` is what acted since the last one.

        Returns the filtered ``(position, velocity)``.
        """
        z = np.stack([position, velocity], axis=-1)  # (n, 2)
        if self.x is None or self.time_s is None or not (0 < time_s - self.time_s < 1.0):
            self.x = z.copy()
            self.P = np.broadcast_to(self.R, (self.joint_count, 2, 2)).copy()
            self.time_s = time_s
            return position.copy(), velocity.copy()
        dt = time_s - self.time_s
        self.time_s = time_s
        q, v = self.x[:, 0], self.x[:, 1]
        F = self._transition(q, v, torque, dt)
        steps = max(1, int(np.ceil(dt / self.config.model_step_s - 1e-9)))
        for _ in range(steps):
            q, v = self.predictor(q, v, torque, dt / steps)
        x_pred = np.stack([q, v], axis=-1)
        G = np.array([0.5 * dt * dt, dt])
        Q = np.outer(G, G) * self.config.acceleration_noise_std ** 2
        P_pred = F @ self.P @ np.swapaxes(F, -1, -2) + Q
        S = P_pred + self.R
        K = P_pred @ np.linalg.inv(S)
        self.x = x_pred + np.einsum("nij,nj->ni", K, z - x_pred)
        self.P = (np.eye(2) - K) @ P_pred
        return self.x[:, 0].copy(), self.x[:, 1].copy()

    def _transition(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, dt: float) -> np.ndarray:
        """Per joint, the model linearised at ``(q, v)`` over ``dt``: ``(n, 2, 2)``.
        The acceleration's slopes in q (gravity's stiffness, which is
        destabilising on one side of the arm's travel) and in v (damping), from
        one model step each; with only the double integrator, a filter that
        trusts the model (a small acceleration_noise_std) lets its error grow
        where gravity pulls the arm away."""
        h = self.config.model_step_s
        _, v0 = self.predictor(q, v, torque, h)
        F = np.zeros((self.joint_count, 2, 2))
        for j in range(self.joint_count):
            bump = np.zeros(self.joint_count)
            bump[j] = _BUMP_Q
            a_q = (self.predictor(q + bump, v, torque, h)[1][j] - v0[j]) / (h * _BUMP_Q)
            bump[j] = _BUMP_V
            a_v = (self.predictor(q, v + bump, torque, h)[1][j] - v0[j] - _BUMP_V) / (h * _BUMP_V)
            F[j] = [[1.0 + 0.5 * a_q * dt * dt, dt + 0.5 * a_v * dt * dt], [a_q * dt, 1.0 + a_v * dt]]
        return F

    def velocity_at_instant(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """The velocity (rad/s) at the instant of the state ``(position, velocity)``
        under ``torque`` (N·m): the mean of the velocity over the model step that
        ended there (the state's own) and over the one that starts there. It
        is what a reference's velocity at that instant compares with: with the
        state's own, an arm exactly on the reference shows a velocity error of
        acceleration × model_step_s / 2, which the law's D term turns into a
        systematic torque (0.3 mrad of tracking error on the reference sine)."""
        _, ahead = self.predictor(position, velocity, torque, self.config.model_step_s)
        return 0.5 * (velocity + ahead)
