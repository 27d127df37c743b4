"""Discrete LQR with integral action, designed at the control rate. Feedforward carries the reference motion
and gravity, so the feedback acts on the tracking error, ``J ë + b ė = u_fb`` per joint, over ``[∫e dt, e, ė]``
(zero-order hold): ``u_fb = −K x`` is a PID on the velocity error with the designed gains."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.pid import BuiltinLaw, DerivativeSource, PidConfig, design_inertia

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


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
    """Solve the discrete Riccati equation; raise if the result does not stabilise. The design is kept for the same
    numbers: a live change is checked off the loop's thread, and the tick that takes it over finds it solved."""
    q_weights = np.asarray(q_weights, dtype=float)
    if q_weights.shape != (3,) or np.any(q_weights < 0) or not np.all(np.isfinite(q_weights)):
        raise ConfigError(f"lqr_q: expected three finite weights >= 0 (integral, position, velocity), got {q_weights}")
    if not np.isfinite(r_weight) or r_weight <= 0:
        raise ConfigError(f"lqr_r: must be > 0, got {r_weight}")
    return _solved(float(inertia), float(damping), float(dt), tuple(q_weights.tolist()), float(r_weight))


@lru_cache(maxsize=256)  # an arm's joints times the handful of weights a session tries
def _solved(inertia: float, damping: float, dt: float, q_weights: tuple[float, ...], r_weight: float) -> LqrDesign:
    A, B = discretise(inertia, damping, dt)
    Q, R = np.diag(q_weights), np.array([[r_weight]])
    from scipy.linalg import solve_discrete_are

    P = solve_discrete_are(A, B, Q, R)
    K = np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
    radius = float(np.max(np.abs(np.linalg.eigvals(A - B @ K))))
    if not radius < 1.0:
        raise ConfigError(f"LQR design does not stabilise the arm (spectral radius {radius:.4f})")
    for shared in (A, B, K, P):  # one design serves every caller: none may change it
        shared.setflags(write=False)
    return LqrDesign(A, B, K, P, radius)


def torque_weight(lqr_r: float, reference_inertia_kgm2: float, inertia_kgm2: float) -> float:
    """``lqr_r`` scaled so an acceleration costs the same on every joint (as it is for a joint of the reference
    inertia, or everywhere when that is 0): every joint's error dies away alike."""
    if reference_inertia_kgm2 <= 0:
        return lqr_r
    return lqr_r * (reference_inertia_kgm2 / inertia_kgm2) ** 2


def designed_gains(
    pid: PidConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    period_s: float,
    lqr_q: tuple[float, float, float],
    lqr_r: float | Sequence[float],
    reference_inertia: float = 0.0,
    design_position: tuple[float, ...] | None = None,
    payload_kg: float = 0.0,
) -> PidConfig:
    """``pid`` with its gains replaced by each joint's LQR design at ``period_s`` (D on the velocity error), on
    the inertias at ``design_position`` allowing for ``payload_kg`` (:func:`design_inertia`)."""
    if dynamics is None:
        raise ConfigError("controller_type lqr: needs the arm model (urdf_path)")
    inertia = design_inertia(dynamics, joint_count, design_position, payload_kg)
    torque_weights = np.broadcast_to(np.asarray(lqr_r, dtype=float), (joint_count,))
    gains = np.array(
        [
            design(
                inertia[j],
                dynamics.damping[j],
                period_s,
                np.array(lqr_q),
                torque_weight(float(torque_weights[j]), reference_inertia, inertia[j]),
            ).K[0]
            for j in range(joint_count)
        ]
    )
    return replace(
        pid, ki=gains[:, 0], kp=gains[:, 1], kd=gains[:, 2], derivative_source=DerivativeSource.VELOCITY_ERROR
    )


class LqrLaw(BuiltinLaw):
    """The built-in law with its gains from a discrete LQR design with lqr_q and lqr_r."""

    kind: ClassVar[str] = "lqr"

    def gains(self) -> PidConfig:
        p = self.params
        return designed_gains(
            p["pid"],
            self.arm.model,
            self.arm.joint_count,
            self.period_s,
            p["lqr_q"],
            p["lqr_r"],
            p["reference_inertia"],
            p["design_position"],
            p.get("rated_payload_kg", 0.0),
        )
