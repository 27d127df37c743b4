"""The world's holding brakes: on before the first effort (``start``), on the drive's request (``requested``), on
the e-stop (``estop``) and when efforts stop coming (``drive_timeout``: the loop's clock judges when); any reason
holds them. A braked joint gets no actuator torque and is held by its brake's dry friction. Their state goes out on
port ``brakes``: 1 per joint while engaged, and why in its label (``engaged:drive_timeout``; ``engaged:`` released)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from robot_controller.blocks.values import Array

if TYPE_CHECKING:  # light: readers of the label (scoring) import this module without the physics
    from robot_controller.core.model import MujocoPlant

#: The brakes' label: ``engaged:`` and why they hold, comma-separated (nothing when released).
BRAKES_LABEL_PREFIX = "engaged:"
REASONS = ("start", "drive_timeout", "requested", "estop")


def brakes_label(reasons: set[str]) -> str:
    return BRAKES_LABEL_PREFIX + ",".join(sorted(reasons))


class Brakes:
    """Why each brake is on; engaged on every joint at once while any reason holds."""

    def __init__(self, plant: MujocoPlant, holding_torque_nm: float) -> None:
        """:param holding_torque_nm: each brake's dry friction, N·m"""
        self.plant = plant
        self.joint_count = len(plant.joint_names)
        self.holding_torque_nm = holding_torque_nm
        self.reasons: set[str] = {"start"}
        plant.set_brakes(np.ones(self.joint_count, dtype=bool), holding_torque_nm)

    @property
    def engaged(self) -> bool:
        return bool(self.reasons)

    def set(self, reason: str, on: bool) -> bool:
        """Add or remove one reason; whether the brakes engaged or released by it."""
        before = self.engaged
        (self.reasons.add if on else self.reasons.discard)(reason)
        if self.engaged == before:
            return False
        self.plant.set_brakes(np.full(self.joint_count, self.engaged), self.holding_torque_nm)
        return True

    def value(self) -> Array:
        """Port ``brakes``: 1 per engaged joint, the reasons in the label."""
        return Array(np.full(self.joint_count, 1.0 if self.reasons else 0.0), brakes_label(self.reasons))
