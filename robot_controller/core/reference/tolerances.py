"""A FollowJointTrajectory goal's tolerances, read as ros2_controllers' JointTrajectoryController reads them, and its
error codes.

Per joint, a tolerance given in the goal (``control_msgs/JointTolerance``: name, position, velocity) is used if it is
positive, the controller's default if it is 0, and none (never violated) if it is negative; a default of 0 is none.
While the trajectory runs, |desired − actual| beyond a path tolerance aborts the goal (``PATH_TOLERANCE_VIOLATED``);
from its end, the goal succeeds once every joint is within its goal tolerance, or aborts
(``GOAL_TOLERANCE_VIOLATED``) if it is not within ``goal_time_s`` after the end (0: no limit).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

# control_msgs/action/FollowJointTrajectory's result codes.
SUCCESSFUL = 0
INVALID_GOAL = -1
INVALID_JOINTS = -2
OLD_HEADER_TIMESTAMP = -3
PATH_TOLERANCE_VIOLATED = -4
GOAL_TOLERANCE_VIOLATED = -5
#: How the server's log line for a rejected goal begins (the action protocol's answer carries no reason: a client that
#: wants it reads the line from the log topic, ``rosout``).
GOAL_REJECTED_LOG = "goal rejected: "

#: One JointTolerance as the goal gives it: (joint name, position, velocity); rad and rad/s (m, m/s on a slider).
GivenTolerance = tuple[str, float, float]


@dataclass(frozen=True)
class Tolerances:
    """Per joint (the arm's order), rad and rad/s; ``inf`` where not checked."""

    path_position: np.ndarray
    path_velocity: np.ndarray
    goal_position: np.ndarray
    goal_velocity: np.ndarray
    goal_time_s: float  #: after the trajectory's end; 0: no limit

    def path_violation(self, joint_names: Sequence[str], error: np.ndarray, velocity_error: np.ndarray) -> str | None:
        """The first joint outside its path tolerance, in one line (None if every joint is within)."""
        return _outside("path", joint_names, error, velocity_error, self.path_position, self.path_velocity)

    def goal_miss(self, joint_names: Sequence[str], error: np.ndarray, velocity_error: np.ndarray) -> str | None:
        """The first joint outside its goal tolerance, in one line (None: the goal is reached)."""
        return _outside("goal", joint_names, error, velocity_error, self.goal_position, self.goal_velocity)


def _outside(what, joint_names, error, velocity_error, position_tolerance, velocity_tolerance) -> str | None:
    for values, tolerance, unit in ((error, position_tolerance, "rad"), (velocity_error, velocity_tolerance, "rad/s")):
        excess = np.abs(values) - tolerance
        if np.any(excess > 0):
            j = int(np.argmax(excess))
            quantity = "position" if unit == "rad" else "velocity"
            return (
                f"{joint_names[j]} {quantity} error {values[j]:+.4g} {unit} is outside its {what} tolerance "
                f"±{tolerance[j]:.4g} {unit}"
            )
    return None


def _resolve(given: float, default: float) -> float:
    value = given if given != 0.0 else default
    return float("inf") if value <= 0.0 or not np.isfinite(value) else float(value)


def _per_joint(
    joint_names: Sequence[str], given: Sequence[GivenTolerance], default_position: float, default_velocity: float
) -> tuple[np.ndarray, np.ndarray] | str:
    position = np.full(len(joint_names), _resolve(0.0, default_position))
    velocity = np.full(len(joint_names), _resolve(0.0, default_velocity))
    for name, position_given, velocity_given in given:
        if name not in joint_names:
            return f"a tolerance names joint {name!r}, not one of the arm's {list(joint_names)}"
        if not (np.isfinite(position_given) and np.isfinite(velocity_given)):
            return f"the tolerance of {name} is not finite"
        j = list(joint_names).index(name)
        position[j] = _resolve(position_given, default_position)
        velocity[j] = _resolve(velocity_given, default_velocity)
    return position, velocity


def goal_tolerances(
    joint_names: Sequence[str],
    path: Sequence[GivenTolerance],
    goal: Sequence[GivenTolerance],
    goal_time_s: float,
    *,
    default_path_rad: float,
    default_goal_rad: float,
    default_goal_time_s: float,
) -> Tolerances | str:
    """The tolerances in force for a goal (module docstring), or why the goal's are invalid. The defaults are the
    controller's parameters (0: none); velocity tolerances default to none."""
    along = _per_joint(joint_names, path, default_path_rad, 0.0)
    if isinstance(along, str):
        return along
    at_end = _per_joint(joint_names, goal, default_goal_rad, 0.0)
    if isinstance(at_end, str):
        return at_end
    if not np.isfinite(goal_time_s) or goal_time_s < 0.0:
        return f"goal_time_tolerance {goal_time_s:g} s is negative or not finite"
    return Tolerances(*along, *at_end, goal_time_s=goal_time_s if goal_time_s > 0.0 else default_goal_time_s)
