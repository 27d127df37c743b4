"""The Kalman filter's tuning (:class:`KalmanConfig`) and its process noise: what the
filter assumes of the arm's unmodelled acceleration and of the external torque, apart
from the filter's arithmetic so that the controller's configuration and the gain design
(:mod:`robot_controller.core.estimation.kalman_linear`) read them without the filter."""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from robot_controller.core.errors import ConfigError

# N·m, σ of the disturbance estimate when the filter (re)starts: nothing is known
# of it yet, so the first readings set it (a couple of periods).
DISTURBANCE_PRIOR_STD_NM = 2.0


@dataclass(frozen=True)
class KalmanConfig:
    """:param position_noise_std: measurement σ on position, rad
    :param velocity_noise_std: measurement σ on velocity, rad/s
    :param acceleration_noise_std: σ of the unmodelled acceleration, rad/s²
    :param disturbance_noise_std: how fast the external torque may change, N·m/√s
        (σ of its random walk; used only when the filter estimates it)
    """

    position_noise_std: float = 0.005
    velocity_noise_std: float = 0.02
    acceleration_noise_std: float = 0.005
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (the simulator's physics step, 1 ms in the reference scenario), so that the prediction and
    #: the readings agree (a coarser step puts the predicted position off by about a·T·step/2)
    model_step_s: float = 0.001
    disturbance_noise_std: float = 0.0001
    #: a reading this many σ (Mahalanobis distance of its innovation) from the prediction, among
    #: readings that otherwise agree with the filter, is taken as a sudden external torque (a push, a
    #: collision, a load let go): the observer allows its torque a jump (σ DISTURBANCE_PRIOR_STD_NM)
    #: that period and follows it within a period or two, while between jumps the torque may change
    #: only slowly (disturbance_noise_std). 0: never.
    jump_detection_sigma: float = 5.0
    #: the σ the filter moves to while its readings disagree with it (an arm unlike its model,
    #: readings later than their stamps): it then follows the readings rather than its model
    mismatch_acceleration_noise_std: float = 2.0
    mismatch_disturbance_noise_std: float = 0.3
    #: s, how uncertain the instant is from which a new command acts on the arm: 0 where commands take
    #: effect on a known schedule (lockstep, the in-process loop); on the wall clock, the command path's
    #: latency and its jitter. A change of command Δτ then leaves the velocity uncertain by Δτ·this/inertia.
    command_timing_uncertainty_s: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "position_noise_std",
            "velocity_noise_std",
            "acceleration_noise_std",
            "model_step_s",
            "disturbance_noise_std",
            "mismatch_acceleration_noise_std",
            "mismatch_disturbance_noise_std",
        ):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")
        if not np.isfinite(self.command_timing_uncertainty_s) or self.command_timing_uncertainty_s < 0:
            raise ConfigError(
                f"command_timing_uncertainty_s: must be a finite number ≥ 0, got {self.command_timing_uncertainty_s}"
            )
        if not np.isfinite(self.jump_detection_sigma) or self.jump_detection_sigma < 0:
            raise ConfigError(f"jump_detection_sigma: must be a finite number ≥ 0, got {self.jump_detection_sigma}")

    def for_inertia(self, torque_scale: float) -> KalmanConfig:
        """The filter with its torque figures (the observer's σs) ``torque_scale`` times larger: for a
        joint that much heavier than the one they were chosen for, the same in acceleration."""
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
    """The filter's process noise over ``dt`` s: ``(2, 2)`` on ``[q, v]`` from
    the white unmodelled acceleration; with ``acceleration_per_nm`` (rad/s² per
    N·m on each joint, shape ``(n,)``: the disturbance observer) ``(n, 3, 3)``
    on ``[q, v, d]``, adding the random walk of ``d`` carried through the double
    integrator over ``dt`` (the continuous model's, exactly)."""
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
    """The four parts of the process noise on ``[q, v, d]`` over ``dt`` s, flattened (4, 9):
    ``A``, the white acceleration through the double integrator (``G·Gᵀ``, G = [dt²/2, dt]);
    ``B``, ``C``, ``D``, the random walk of ``d`` carried through it, in ``[q, v]``, between
    ``[q, v]`` and ``d``, and in ``d`` itself (:func:`process_noise` weighs them). Shared
    between calls (cached): read only."""
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
