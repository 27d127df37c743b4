"""What the Kalman filter makes of each reading's surprise (its innovation:
the reading minus the prediction), per joint: whether the readings agree with
the filter, how far its process noise moves towards following them, whether
a surprise is a jump of the external torque, and whether it is beyond any
torque at all.

Agreement is the innovation's squared Mahalanobis distance (χ² with 2 degrees
of freedom, mean 2 when the readings agree with the filter), averaged over
about CONSISTENCY_TIME_S. From MISMATCH_FROM on, the process noise moves
towards the mismatch σ, which it reaches at MISMATCH_FROM + MISMATCH_SPAN. A
jump is taken only below MISMATCH_FROM: a reading that stands out from
readings that agree. No ROS, no clocks: arrays per joint.
"""

from __future__ import annotations

import numpy as np

from robot_controller.core.arrays import clip

CONSISTENCY_TIME_S = 0.3
MISMATCH_FROM = 4.0
MISMATCH_SPAN = 2.0
#: A jump is taken only when what a torque step leaves unexplained of a reading's surprise is
#: noise: below this squared distance (χ² with 1 degree of freedom: 3 σ).
JUMP_RESIDUAL_MAX = 9.0
#: Where a (re)started filter's average starts: fully disagreeing, until its readings show otherwise.
UNPROVEN_DISTANCE_SQ = MISMATCH_FROM + MISMATCH_SPAN
#: σ of noise to spare before a reading counts as beyond any external torque.
BEYOND_SIGMA = 5.0


def agreeing(average: np.ndarray) -> np.ndarray:
    """Per joint, whether the readings have agreed with the filter lately."""
    return average < MISMATCH_FROM


def updated_average(average: np.ndarray, distance_sq: np.ndarray, jumped: np.ndarray, dt: float) -> np.ndarray:
    """The running average of the squared distance after a reading ``dt`` s on.
    A reading taken as a jump is explained by it: it does not count as disagreement."""
    alpha = min(1.0, dt / CONSISTENCY_TIME_S)
    return np.where(jumped, average, average + alpha * (distance_sq - average))


def noise_in_force(
    average: np.ndarray, agreeing_std: tuple[float, float] | np.ndarray, mismatch_std: tuple[float, float] | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the σ of the disturbance's random walk (N·m/√s) and of the
    unmodelled acceleration (rad/s²): ``agreeing_std`` (both, in that order)
    while the readings agree with the filter, moving (in variance, linearly
    with the average distance) to ``mismatch_std`` as they stop agreeing. A
    filter that trusts its model averages the sensor noise away; one whose
    model is wrong must follow the readings instead."""
    if (average <= MISMATCH_FROM).all():  # every joint agrees (w = 0): the formula gives these back exactly
        n = np.shape(average)[0]
        return np.full(n, float(agreeing_std[0])), np.full(n, float(agreeing_std[1]))
    w = clip((average - MISMATCH_FROM) / MISMATCH_SPAN, 0.0, 1.0)
    near, far = np.asarray(agreeing_std, float), np.asarray(mismatch_std, float)
    variance = near**2 + w[:, None] * (far**2 - near**2)
    return np.sqrt(variance[:, 0]), np.sqrt(variance[:, 1])


def looks_like_a_jump(
    surprise: np.ndarray, S_inv: np.ndarray, distance_sq: np.ndarray, step: np.ndarray, sigma: float
) -> np.ndarray:
    """Per joint, whether a reading's surprise (n, 2: position, velocity) is
    that of a torque step at the start of the period, a generalised likelihood
    ratio test. ``step`` (n, 2) is how much a step of 1 N·m moves the reading
    over the period: ``b·dt²/2`` in position and ``b·dt`` in velocity, so it
    is almost all velocity. The part of the squared distance a step explains
    must exceed ``sigma``², and what is left must be no more than noise. A
    reading late by more than its stamp says is surprising mostly in position,
    and is not taken for a push."""
    along = np.einsum("ni,nij,nj->n", step, S_inv, surprise)
    weight = np.einsum("ni,nij,nj->n", step, S_inv, step)
    explained = along**2 / weight
    return (explained > sigma**2) & (distance_sq - explained < JUMP_RESIDUAL_MAX)


def beyond_any_disturbance(surprise: np.ndarray, S: np.ndarray, velocity_per_nm: np.ndarray, limit: np.ndarray):
    """Per joint, whether the reading's velocity is further from the prediction
    than any external torque within ``limit`` (N·m) could have moved it over
    the period (``velocity_per_nm``: rad/s per N·m acting for the period), with
    BEYOND_SIGMA of noise to spare. That happens with a brake that held the arm,
    a hard contact, or a reading from before a fault. Such a reading is true
    but says nothing of a torque that will go on acting: the filter starts
    again from it (the external torque back to 0). Estimating a torque at the
    limit instead would command against a force that is gone."""
    reach = limit * velocity_per_nm + BEYOND_SIGMA * np.sqrt(S[:, 1, 1])
    return np.abs(surprise[:, 1]) > reach
