"""The Kalman filter's tuning (:class:`KalmanConfig`) and its process noise: what the
filter assumes of the arm's unmodelled acceleration and of the external torque."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from robot_controller.core.errors import ConfigError

# N·m, σ of the disturbance estimate when the filter (re)starts: the first readings set it.
DISTURBANCE_PRIOR_STD_NM = 2.0


@dataclass(frozen=True)
class KalmanConfig:
    """The filter's tuning.

    :param position_noise_std: measurement σ on position, rad
    :param velocity_noise_std: measurement σ on velocity, rad/s
    :param acceleration_noise_std: σ of the unmodelled acceleration, rad/s²
    :param disturbance_noise_std: how fast the external torque may change, N·m/√s
        (σ of its random walk; used only when the filter estimates it)
    """

    position_noise_std: float = 0.005
    velocity_noise_std: float = 0.02
    acceleration_noise_std: float = 0.005
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (a coarser step puts the predicted position off by about a·T·step/2)
    model_step_s: float = 0.001
    disturbance_noise_std: float = 0.0001
    #: a reading this many σ from the prediction, among readings that agree with the filter, is a
    #: sudden external torque: the observer allows its torque a jump (σ DISTURBANCE_PRIOR_STD_NM)
    #: that period; between jumps it changes only slowly (disturbance_noise_std). 0: never.
    jump_detection_sigma: float = 5.0
    #: the σ the filter moves to while its readings disagree with it (an arm unlike its model,
    #: readings later than their stamps): it then follows the readings rather than its model
    mismatch_acceleration_noise_std: float = 2.0
    mismatch_disturbance_noise_std: float = 0.3
    #: s, how uncertain the instant is from which a new command acts: 0 on a known schedule (lockstep);
    #: on the wall clock, the command path's jitter. A change Δτ leaves the velocity uncertain by Δτ·this/I.
    command_timing_uncertainty_s: float = 0.0

    def __post_init__(self) -> None:
        positive = ("position_noise_std", "velocity_noise_std", "acceleration_noise_std", "model_step_s")
        positive += ("disturbance_noise_std", "mismatch_acceleration_noise_std", "mismatch_disturbance_noise_std")
        for name in (*positive, "command_timing_uncertainty_s", "jump_detection_sigma"):
            value, strict = getattr(self, name), name in positive
            if not np.isfinite(value) or value < 0 or (strict and value == 0):
                raise ConfigError(f"{name}: must be a finite number {'>' if strict else '≥'} 0, got {value}")

    def for_inertia(self, torque_scale: float) -> KalmanConfig:
        """The observer's σs ``torque_scale`` times larger: a joint that much heavier, the same in acceleration."""
        return replace(
            self,
            disturbance_noise_std=self.disturbance_noise_std * torque_scale,
            mismatch_disturbance_noise_std=self.mismatch_disturbance_noise_std * torque_scale,
        )

    def at_mismatch(self) -> KalmanConfig:
        """The filter as it is while its readings disagree with it (the most it moves to)."""
        return replace(
            self,
            acceleration_noise_std=max(self.acceleration_noise_std, self.mismatch_acceleration_noise_std),
            disturbance_noise_std=max(self.disturbance_noise_std, self.mismatch_disturbance_noise_std),
        )


def process_noise(
    config: KalmanConfig,
    dt: float,
    acceleration_per_nm: np.ndarray | None = None,
    disturbance_noise_std: np.ndarray | None = None,
    acceleration_noise_std: np.ndarray | None = None,
) -> np.ndarray:
    """The process noise over ``dt`` s: ``(2, 2)`` on ``[q, v]`` from the white unmodelled acceleration;
    with ``acceleration_per_nm`` (the observer) ``(n, 3, 3)`` on ``[q, v, d]``, adding ``d``'s random walk.

    :param acceleration_per_nm: rad/s² per N·m on each joint's own axis, (n,)
    :param disturbance_noise_std: per joint, N·m/√s (None: the config's)
    :param acceleration_noise_std: per joint, rad/s² (None: the config's)
    """
    G = (0.5 * dt * dt, dt)
    if acceleration_per_nm is None:
        return np.outer(G, G) * config.acceleration_noise_std**2
    b = np.asarray(acceleration_per_nm, dtype=float).reshape(-1)
    sigma_a = config.acceleration_noise_std if acceleration_noise_std is None else acceleration_noise_std
    sigma_d = config.disturbance_noise_std if disturbance_noise_std is None else disturbance_noise_std
    # Per joint, Q = σa²·A + w·b²·B + w·b·C + w·D (w = σd²): one product with the templates.
    weights = np.empty((b.size, 4))
    weights[:, 0] = np.square(sigma_a)
    weights[:, 3] = w = np.square(sigma_d)
    weights[:, 2] = wb = w * b
    weights[:, 1] = wb * b
    return weights.dot(_noise_templates(dt)).reshape(b.size, 3, 3)


@lru_cache(maxsize=64)  # a filter's periods are a handful of roundings of one period
def _noise_templates(dt: float) -> np.ndarray:
    """The process noise's four parts over ``dt`` s, (4, 9), read only: the white acceleration (``G·Gᵀ``,
    G = [dt²/2, dt]), and ``d``'s random walk in ``[q, v]``, between ``[q, v]`` and ``d``, and in ``d``."""
    g0, g1 = 0.5 * dt * dt, dt
    qq, qv, vv = dt**5 / 20, dt**4 / 8, dt**3 / 3
    qd, vd = dt**3 / 6, dt**2 / 2
    templates = np.array(
        [
            [g0 * g0, g0 * g1, 0.0, g0 * g1, g1 * g1, 0.0, 0.0, 0.0, 0.0],
            [qq, qv, 0.0, qv, vv, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, qd, 0.0, 0.0, vd, qd, vd, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt],
        ]
    )
    templates.flags.writeable = False
    return templates


@lru_cache(maxsize=64)
def timing_noise_template(dt: float) -> np.ndarray:
    """``G·Gᵀ`` over ``dt`` s, G = [dt, 1] (2, 2), read only: a velocity step of unknown size at the
    start of the period, in ``[q, v]``."""
    G = np.array([dt, 1.0])
    template = np.outer(G, G)
    template.flags.writeable = False
    return template
