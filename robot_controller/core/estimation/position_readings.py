"""Readings of the positions alone, each with its own σ and their correlation (a camera's): the noise the filter
takes them with, and how it starts a joint from one."""

from __future__ import annotations

import numpy as np

#: rad, rad/s: the σ a reading that says nothing of a joint's position (a camera that sees no marker constraining it)
#: or velocity (a camera measures none) is taken with: finite, so the algebra stays the same, and so large that the
#: filter runs that joint on its model
UNMEASURED_STD = 1e3

#: rad/s: how uncertain a joint's velocity is when the filter starts it from a reading that has none (the model's
#: prediction, or rest at the start)
UNREAD_DISTURBANCE_START_STD = 0.2
UNREAD_VELOCITY_START_STD = 0.1


def position_covariance(position_std: np.ndarray, correlation: np.ndarray | None) -> np.ndarray:
    """The positions' error covariance (n, n) from their σs (``inf``: :data:`UNMEASURED_STD`, uncorrelated) and
    correlation (None: independent)."""
    sigma = np.minimum(np.asarray(position_std, dtype=float), UNMEASURED_STD)
    if correlation is None:
        return np.diag(np.square(sigma))
    rho = np.array(correlation, dtype=float)
    blind = sigma >= UNMEASURED_STD
    rho[blind, :] = 0.0
    rho[:, blind] = 0.0
    np.fill_diagonal(rho, 1.0)
    return rho * np.outer(sigma, sigma)


def reading_noise(position_std: np.ndarray) -> np.ndarray:
    """A position-only reading's R per joint, (n, 2, 2): its σ (``inf``: :data:`UNMEASURED_STD`), its velocity
    unmeasured."""
    sigma = np.minimum(np.asarray(position_std, dtype=float), UNMEASURED_STD)
    R = np.zeros((sigma.size, 2, 2))
    R[:, 0, 0] = np.square(sigma)
    R[:, 1, 1] = UNMEASURED_STD**2
    return R


def positions_update(
    x: np.ndarray, P: np.ndarray, q_at: np.ndarray, position: np.ndarray, covariance: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The Kalman update of states ``x`` (groups, size) with covariances ``P`` (groups, size, size) on a reading of
    the positions alone (at ``q_at`` in each group's state), their errors' ``covariance`` (joints, joints; one
    group's joints together). Returns the new ``x`` and ``P`` (symmetrised)."""
    g, k = P.shape[0], len(np.atleast_1d(q_at))
    q_at = np.asarray(q_at).reshape(-1)
    P_q = P[:, q_at, :]  # (g, k, size)
    S = P_q[:, :, q_at] + (covariance if k > 1 else np.diagonal(covariance).reshape(g, 1, 1))
    K = np.linalg.solve(S, P_q).transpose(0, 2, 1)  # (g, size, k)
    surprise = np.asarray(position, dtype=float).reshape(g, k) - x[:, q_at]
    x = x + np.matmul(K, surprise[:, :, None])[:, :, 0]
    P = P - np.matmul(K, P_q)
    return x, 0.5 * (P + P.transpose(0, 2, 1))
