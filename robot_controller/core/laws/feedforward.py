"""Model feedforward: the torque the reference motion needs, and the map that decouples
the feedback on a chain of joints, both from the arm model."""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


class FeedforwardMode(StrEnum):
    NONE = "none"
    GRAVITY = "gravity"  #: gravity at the reference position
    FULL = "full"  #: inertia·a_ref + damping·v_ref + gravity(q_ref)


def feedforward_torque(
    mode: FeedforwardMode,
    dynamics: ArmDynamics | None,
    position: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
) -> np.ndarray:
    """Feedforward torque (N·m) for the reference ``(position, velocity, acceleration)``."""
    if mode is FeedforwardMode.NONE or dynamics is None:
        return np.zeros(np.shape(position))
    if mode is FeedforwardMode.GRAVITY:
        return dynamics.gravity(position)
    return dynamics.torque(position, velocity, acceleration)


def decoupling_map(decoupling: bool, dynamics: ArmDynamics | None, position: np.ndarray) -> np.ndarray | None:
    """``M(q)·diag(M(q))⁻¹`` at ``position``: the torques that give each joint the acceleration its
    own gains ask for (``τ_j / M_jj``) on a chain whose inertias couple (the feedback half of
    computed-torque control). None when ``decoupling`` is off, on one joint or without the arm model."""
    if not decoupling or dynamics is None or np.size(position) < 2:
        return None
    mass = dynamics.mass_matrix(position)
    return mass / np.diag(mass)[None, :]
