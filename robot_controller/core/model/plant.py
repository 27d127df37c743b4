"""The physical arm as the loop and the simulator node step it: the ``Plant`` protocol.

Anything that moves joints (the MuJoCo plant, an analytic model, Gazebo behind a
bridge, a hardware driver) can stand in by providing these few members.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Plant(Protocol):
    joint_names: list[str]
    joint_units: list[str]  #: "rad" or "m" per joint
    physics_dt: float

    @property
    def time_s(self) -> float: ...

    def reset(self, position: np.ndarray, velocity: np.ndarray | None = None) -> None: ...

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None: ...

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """True ``(position rad, velocity rad/s)`` per joint."""
        ...
