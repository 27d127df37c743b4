"""What the arm is asked to do: trajectories, waypoint trajectories and their quintic
paths, and whether the arm can follow them."""

from robot_controller.core.reference.crossfade import Crossfade, crossfade
from robot_controller.core.reference.feasibility import (
    Plan,
    check_feasibility,
    peak_torque,
    plan_trajectory,
)
from robot_controller.core.reference.joint_trajectory import (
    MAX_START_DELAY_S,
    START_TOLERANCE_RAD,
    Accepted,
    accept_joint_trajectory,
    start_delay,
)
from robot_controller.core.reference.trajectory import (
    MODES,
    Chirp,
    MinTimeStep,
    Sine,
    Trajectory,
    make_trajectory,
    time_scaled,
)

__all__ = [
    "MAX_START_DELAY_S",
    "MODES",
    "START_TOLERANCE_RAD",
    "Accepted",
    "Chirp",
    "Crossfade",
    "MinTimeStep",
    "Plan",
    "Sine",
    "Trajectory",
    "accept_joint_trajectory",
    "check_feasibility",
    "crossfade",
    "make_trajectory",
    "peak_torque",
    "plan_trajectory",
    "start_delay",
    "time_scaled",
]
