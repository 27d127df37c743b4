"""What the Kalman filter makes of each reading's surprise (the reading minus the prediction), per
joint. Agreement is the innovation's squared Mahalanobis distance (χ² with 2 degrees of freedom,
mean 2 while the readings agree), averaged over about CONSISTENCY_TIME_S. From MISMATCH_FROM on,
the process noise moves towards the mismatch σ, reached at MISMATCH_FROM + MISMATCH_SPAN. A jump
is taken only below MISMATCH_FROM: a reading that stands out from readings that agree."""

from __future__ import annotations

import numpy as np
from numpy._core.multiarray import c_einsum  # np.einsum's own C function, without its Python wrapper

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
#: The share of σ² a squared distance stays below to be clearly within σ (rounding is far smaller).
CLEAR_SHARE = 0.999


def quadratic(u: np.ndarray, A: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per joint, ``uᵀ·A·w`` for 2-vectors ``u``, ``w`` (n, 2) and matrices ``A`` (n, 2, 2)."""
    return c_einsum("ni,nij,nj->n", u, A, w)


def noise_in_force(
    average: np.ndarray, agreeing_std: tuple[float, float] | np.ndarray, mismatch_std: tuple[float, float] | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, the σ of the disturbance's random walk (N·m/√s) and of the unmodelled
    acceleration (rad/s²): ``agreeing_std`` (both, in that order) while the readings agree
    with the filter, moving (in variance, linearly with the average distance) to
    ``mismatch_std`` as they stop agreeing: a filter whose model is wrong follows the readings."""
    if (average <= MISMATCH_FROM).all():  # every joint agrees (w = 0): the formula gives these back exactly
        n = np.shape(average)[0]
        return np.full(n, float(agreeing_std[0])), np.full(n, float(agreeing_std[1]))
    w = np.clip((average - MISMATCH_FROM) / MISMATCH_SPAN, 0.0, 1.0)
    near, far = np.asarray(agreeing_std, float), np.asarray(mismatch_std, float)
    variance = near**2 + w[:, None] * (far**2 - near**2)
    return np.sqrt(variance[:, 0]), np.sqrt(variance[:, 1])


def looks_like_a_jump(
    surprise: np.ndarray, S_inv: np.ndarray, distance_sq: np.ndarray, step: np.ndarray, sigma: float
) -> np.ndarray:
    """Per joint, whether a reading's surprise (n, 2) is that of a torque step at the start of the period (a
    generalised likelihood ratio test, ``step``: how much 1 N·m moves the reading): the part of the squared distance
    a step explains exceeds ``sigma``², and what is left is noise. A late reading, surprising mostly in position,
    is not taken for a push."""
    along = quadratic(step, S_inv, surprise)
    weight = quadratic(step, S_inv, step)
    explained = along**2 / weight
    return (explained > sigma**2) & (distance_sq - explained < JUMP_RESIDUAL_MAX)


def beyond_any_disturbance(surprise: np.ndarray, S: np.ndarray, velocity_per_nm: np.ndarray, limit: np.ndarray):
    """Per joint, whether the reading's velocity is further from the prediction than any external torque within
    ``limit`` (N·m; ``velocity_per_nm`` over the period) could have moved it, with BEYOND_SIGMA to spare (a brake
    that held the arm, a hard contact). Such a reading says nothing of a torque that goes on acting: the filter
    starts again from it rather than command against a force that is gone."""
    reach = limit * velocity_per_nm + BEYOND_SIGMA * np.sqrt(S[:, 1, 1])
    return np.abs(surprise[:, 1]) > reach


def allow_jumps(P_pred: np.ndarray, jumped: np.ndarray, jump_std: np.ndarray, b: np.ndarray, dt: float, k: int) -> None:
    """Add to each ``jumped`` joint's predicted covariance ``P_pred`` (groups of ``k`` joints, ``[q, v, d]``
    each) that of a jump of its ``d`` (σ ``jump_std`` N·m) at the start of the period: the surprise goes
    to the torque, not to noise. ``b``: rad/s² per N·m on each joint's own axis."""
    for j in np.flatnonzero(jumped):
        G = np.array([0.5 * b[j] * dt * dt, b[j] * dt, 1.0])
        group, first = divmod(j, k)
        own = slice(first * 3, (first + 1) * 3)
        P_pred[group, own, own] += jump_std[j] ** 2 * np.outer(G, G)


def updated_average(average: np.ndarray, distance_sq: np.ndarray, jumped: np.ndarray | None, dt: float) -> np.ndarray:
    """The innovation's squared distance per joint averaged over about ``CONSISTENCY_TIME_S``,
    a reading ``dt`` s on; one taken as a jump (``jumped``) is explained by it: no disagreement."""
    alpha = min(1.0, dt / CONSISTENCY_TIME_S)
    updated = average + alpha * (distance_sq - average)
    if jumped is not None:
        updated[jumped] = average[jumped]
    return updated


_ADJUGATE, _ADJUGATE_SIGN = np.array([3, 1, 2, 0]), np.array([1.0, -1.0, -1.0, 1.0])


def inverse_2x2(A: np.ndarray) -> np.ndarray:
    """The inverses of a stack of 2 × 2 matrices ``(..., 2, 2)``: adjugate over determinant, in C order
    (a quadratic form by ``einsum`` sums in its operands' memory order)."""
    flat = A.reshape(-1, 4)  # a, b, c, d
    det = flat[:, 0] * flat[:, 3] - flat[:, 1] * flat[:, 2]
    return (flat.take(_ADJUGATE, axis=1) / (det[:, None] * _ADJUGATE_SIGN)).reshape(A.shape)  # (x/−y = −x/y)


def clearly_within(distance_sq: np.ndarray, sigma: float) -> bool:
    """Whether every joint's surprise is clearly within ``sigma`` σ: then neither of innovation's tests can hold."""
    return all((distance_sq < CLEAR_SHARE * sigma * sigma).tolist())
