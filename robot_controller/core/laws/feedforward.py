"""Model feedforward: the torque the reference motion needs, from the arm model."""

from __future__ import annotations

from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


class FeedforwardMode(str, Enum):
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
