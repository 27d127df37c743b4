"""Discrete LQR with integral action for the arm, designed at the control rate.

Feedforward (inverse dynamics) carries the reference motion and gravity, so
the feedback acts on the tracking error of the arm linearised about the
reference: ``J ë + b ė = u_fb`` per joint. The design state is
``[∫e dt, e, ė]`` with ``e = q − r``, discretised exactly (zero-order hold)
at the control period; ``u_fb = −K x``. The gain is checked: the closed
loop's spectral radius must be below 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError


@dataclass(frozen=True)
class LqrDesign:
    A: np.ndarray
    B: np.ndarray
    K: np.ndarray  #: (1, 3): gains on ∫e, e, ė
    P: np.ndarray  #: Riccati solution: the cost-to-go of x is xᵀ P x
    spectral_radius: float


def discretise(inertia: float, damping: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order-hold discretisation of ``[∫e, e, ė]' = Ac x + Bc u``."""
    Ac = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -damping / inertia]])
    Bc = np.array([[0.0], [0.0], [1.0 / inertia]])
    block = np.zeros((4, 4))
    block[:3, :3], block[:3, 3:] = Ac, Bc
    from scipy.linalg import expm  # imported on first design: a node's start-up is paid for in seconds

    phi = expm(block * dt)
    return phi[:3, :3], phi[:3, 3:]


def design(inertia: float, damping: float, dt: float, q_weights: np.ndarray, r_weight: float) -> LqrDesign:
    """Solve the discrete Riccati equation; raise if the result does not stabilise."""
    q_weights = np.asarray(q_weights, dtype=float)
    if q_weights.shape != (3,) or np.any(q_weights < 0) or not np.all(np.isfinite(q_weights)):
        raise ConfigError(f"lqr_q: expected three finite weights >= 0 (integral, position, velocity), got {q_weights}")
    if not np.isfinite(r_weight) or r_weight <= 0:
        raise ConfigError(f"lqr_r: must be > 0, got {r_weight}")
    A, B = discretise(inertia, damping, dt)
    Q, R = np.diag(q_weights), np.array([[r_weight]])
    from scipy.linalg import solve_discrete_are

    P = solve_discrete_are(A, B, Q, R)
    K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    radius = float(np.max(np.abs(np.linalg.eigvals(A - B @ K))))
    if not radius < 1.0:
        raise ConfigError(f"LQR design does not stabilise the arm (spectral radius {radius:.4f})")
    return LqrDesign(A, B, K, P, radius)


def delay_margin_periods(A: np.ndarray, B: np.ndarray, K: np.ndarray, max_periods: int = 50) -> int:
    """How many whole control periods of delay the loop ``u = −K x`` survives.

    With the feedback acting ``d`` periods late, ``x[k+1] = A x[k] − B K x[k−d]``:
    the loop is stable while the spectral radius of that system, written over
    the state and the last ``d`` states, is below 1. Returns the largest such
    ``d`` (0: not even one period; ``max_periods``: at least that many).
    """
    n = A.shape[0]
    for delay in range(1, max_periods + 1):
        size = n * (delay + 1)
        M = np.zeros((size, size))
        M[:n, :n] = A
        M[:n, n * delay :] = -B @ K  # the feedback of the oldest stored state
        M[n:, :-n] = np.eye(n * delay)  # shift: x[k] becomes x[k−1], …
        if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
            return delay - 1
    return max_periods
