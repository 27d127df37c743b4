"""State estimation: a Kalman filter on joint position and velocity, with
the applied torque as input, so the controller acts on a cleaner state than
the raw encoder reading.

Per joint, the state is ``x = [q, v]``. The prediction integrates the arm
model (MuJoCo forward dynamics, or the analytic arm) over the control period
under the torque commanded last; its covariance uses the model linearised
about the reference as a constant-velocity-with-acceleration-noise model,
which is what the torque input leaves uncertain. Joints are filtered
independently (the reference arm has one).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError

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

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "velocity_noise_std", "acceleration_noise_std"):
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
        q, v = self.predictor(self.x[:, 0], self.x[:, 1], torque, dt)
        x_pred = np.stack([q, v], axis=-1)
        F = np.array([[1.0, dt], [0.0, 1.0]])
        G = np.array([0.5 * dt * dt, dt])
        Q = np.outer(G, G) * self.config.acceleration_noise_std ** 2
        P_pred = F @ self.P @ F.T + Q  # broadcasts over joints
        S = P_pred + self.R
        K = P_pred @ np.linalg.inv(S)
        self.x = x_pred + np.einsum("nij,nj->ni", K, z - x_pred)
        self.P = (np.eye(2) - K) @ P_pred
        return self.x[:, 0].copy(), self.x[:, 1].copy()
