"""The physical arm: the ``Plant`` protocol, which the loop and the simulator node step.

Anything that moves joints (the MuJoCo plant, an analytic model, Gazebo behind a
bridge, a hardware driver) can stand in by providing the same few members. The
MuJoCo implementation is :mod:`robot_controller.core.model.mujoco_plant`, the model
loading :mod:`robot_controller.core.model.mujoco_model`, the controller's arm model
:mod:`robot_controller.core.model.arm_dynamics`; their names are importable from here too.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from robot_controller.core.model.arm_dynamics import ArmDynamics, OneJointDynamics
from robot_controller.core.model.mujoco_model import (
    can_collide,
    effort_limits,
    joint_names,
    load_model,
    steps_per_period,
)
from robot_controller.core.model.mujoco_plant import (
    BRAKE_LOCK_SPEED,
    MAX_DISTURBANCE_NM,
    MAX_DISTURBANCE_S,
    MujocoPlant,
    check_disturbance,
)

__all__ = [
    "BRAKE_LOCK_SPEED",
    "MAX_DISTURBANCE_NM",
    "MAX_DISTURBANCE_S",
    "ArmDynamics",
    "MujocoPlant",
    "OneJointDynamics",
    "Plant",
    "can_collide",
    "check_disturbance",
    "effort_limits",
    "joint_names",
    "load_model",
    "steps_per_period",
]


class Plant(Protocol):
    joint_names: list[str]
    physics_dt: float

    @property
    def time_s(self) -> float: ...

    def reset(self, position: np.ndarray, velocity: np.ndarray | None = None) -> None: ...

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None: ...

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """True ``(position rad, velocity rad/s)`` per joint."""
        ...
