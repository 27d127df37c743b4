"""The Kalman filter's tuning (:class:`KalmanConfig`: what the filter assumes of the readings' noise,
the arm's unmodelled acceleration and the external torque) and its state's layout (:class:`StateIndex`)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robot_controller.core.errors import ConfigError

# N·m, σ of the disturbance estimate when the filter (re)starts: the first readings set it.
DISTURBANCE_PRIOR_STD_NM = 2.0


@dataclass(frozen=True)
class KalmanConfig:
    """The filter's tuning, every value given (the defaults are the parameter schema's)."""

    position_noise_std: float  #: rad, the reading's σ
    velocity_noise_std: float  #: rad/s, the reading's σ
    acceleration_noise_std: float  #: rad/s², σ of the unmodelled acceleration
    disturbance_noise_std: float  #: N·m/√s, σ of the external torque's random walk (the observer's)
    #: a reading this many σ from the prediction, among readings that agree with the filter, is a
    #: sudden external torque: the observer allows its torque a jump (σ DISTURBANCE_PRIOR_STD_NM)
    #: that period; between jumps it changes only slowly (disturbance_noise_std). 0: never.
    jump_detection_sigma: float
    #: the σ the filter moves to while its readings disagree with it (an arm unlike its model,
    #: readings later than their stamps): it then follows the readings rather than its model
    mismatch_acceleration_noise_std: float
    mismatch_disturbance_noise_std: float
    #: s, how uncertain the instant is from which a new command acts: 0 on a known schedule (sim time);
    #: on the wall clock, the command path's jitter. A change Δτ leaves the velocity uncertain by Δτ·this/I.
    command_timing_uncertainty_s: float
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (a coarser step puts the predicted position off by about a·T·step/2). Not a parameter: the plant's step.
    model_step_s: float = 0.001

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


class StateIndex:
    """Where each joint's quantities sit in a group's state ``[q1, v1, (d1), q2, v2, ...]`` (``m`` per
    joint) and its covariance, made once per filter (slices where each group is one joint)."""

    def __init__(self, k: int, m: int) -> None:
        first = np.arange(k) * m
        self.q, self.v, self.d = first, first + 1, first + 2  #: each joint's q, v and (m = 3) d
        rows = first[:, None, None] + np.arange(m)[:, None]
        #: each joint's own (m, m) block of the covariance, ``P[:, blocks]`` (g, *block_shape)
        self.blocks, self.block_shape = (rows, rows.transpose(0, 2, 1)), (k, m, m)
        #: each joint's own reading block (q and v), ``P[:, own_readings]`` (g, k, 2, 2)
        self.own_readings = (rows[:, :2, :2], rows[:, :2, :2].transpose(0, 2, 1))
        self.read = np.stack([self.q, self.v], axis=-1).reshape(-1)  #: the readings' places, q1, v1, q2...
        self.readings = np.ix_(self.read, self.read)  #: every reading by every reading (2k, 2k)
        qv = np.concatenate([self.q, self.v])
        self.model_slopes = np.ix_(qv, qv)  #: where the model's slopes ([q1..qk, v1..vk] by the same) go
        #: where ``d`` moves each joint's q and v in the transition, ``F[at.q_by_d]``, ``F[at.v_by_d]``
        self.q_by_d, self.v_by_d = (slice(None), self.q, self.d), (slice(None), self.v, self.d)
        #: the same places in the one group's covariance or transition flattened (k > 1 has one group): a flat index
        #: reads and writes several times faster than a tuple of index arrays
        size = k * m
        self.flat_blocks = (self.blocks[0] * size + self.blocks[1]).reshape(-1)
        self.flat_own_readings = (self.own_readings[0] * size + self.own_readings[1]).reshape(-1)
        self.flat_readings = (self.readings[0] * size + self.readings[1]).reshape(-1)
        self.flat_model_slopes = (self.model_slopes[0] * size + self.model_slopes[1]).reshape(-1)
        self.flat_q_by_d, self.flat_v_by_d = self.q * size + self.d, self.v * size + self.d
        self.flat_model_by_d = (self.model_slopes[0] * size + self.d).reshape(-1)
        if k == 1:
            self.q_by_d, self.v_by_d = (slice(None), 0, 2), (slice(None), 1, 2)
            self.blocks, self.block_shape = (slice(None), slice(None)), (m, m)
            self.own_readings = self.model_slopes = (slice(0, 2), slice(0, 2))
            self.read = slice(0, 2)
