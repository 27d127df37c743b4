"""A FollowJointTrajectory goal's tolerances read as JointTrajectoryController reads them (no ROS): per joint, a
given tolerance is used if positive, the controller's default if 0, none if negative, and a default of 0 is none;
a tolerance naming a joint the arm lacks makes the goal invalid; the path and goal checks say in one line which
joint is outside, by how much, against what."""

import math

import numpy as np
import pytest

from robot_controller.core.reference.tolerances import Tolerances, goal_tolerances

ARM = ("shoulder", "elbow", "wrist")
INF = math.inf


def resolve(path=(), goal=(), goal_time_s=0.0, *, path_rad=0.0, goal_rad=0.0, goal_time_default_s=0.0):
    result = goal_tolerances(
        ARM,
        list(path),
        list(goal),
        goal_time_s,
        default_path_rad=path_rad,
        default_goal_rad=goal_rad,
        default_goal_time_s=goal_time_default_s,
    )
    return result


def resolved(*args, **kwargs) -> Tolerances:
    result = resolve(*args, **kwargs)
    assert isinstance(result, Tolerances), result
    return result


@pytest.mark.parametrize("which", ["path", "goal"])
def test_positive_is_used_zero_takes_the_default_negative_is_none(which):
    given = [("shoulder", 0.05, 0.4), ("elbow", 0.0, 0.0), ("wrist", -1.0, -1.0)]
    tolerances = resolved(**{which: given}, path_rad=0.2, goal_rad=0.02)
    position = getattr(tolerances, f"{which}_position")
    velocity = getattr(tolerances, f"{which}_velocity")
    default = {"path": 0.2, "goal": 0.02}[which]
    assert position.tolist() == [0.05, default, INF]  # a negative one is none even with a default
    assert velocity.tolist() == [0.4, INF, INF]  # velocities have no default


def test_joints_the_goal_leaves_out_take_the_default_and_a_default_of_zero_is_none():
    tolerances = resolved(path=[("elbow", 0.1, 0.0)], path_rad=0.3, goal_rad=0.0)
    assert tolerances.path_position.tolist() == [0.3, 0.1, 0.3]  # in the arm's order, whatever the goal's
    assert tolerances.goal_position.tolist() == [INF, INF, INF]
    assert resolved(goal=[("wrist", 0.0, 0.0)]).goal_position.tolist() == [INF, INF, INF]  # 0 over a 0 default


def test_a_tolerance_for_a_joint_the_arm_lacks_or_not_finite_is_refused_in_one_line():
    assert resolve(path=[("knee", 0.1, 0.0)]) == (
        "a tolerance names joint 'knee', not one of the arm's ['shoulder', 'elbow', 'wrist']"
    )
    assert resolve(goal=[("knee", 0.1, 0.0)]).startswith("a tolerance names joint 'knee'")
    assert resolve(goal=[("elbow", math.nan, 0.0)]) == "the tolerance of elbow is not finite"
    assert resolve(path=[("elbow", 0.1, math.inf)]) == "the tolerance of elbow is not finite"


def test_goal_time_given_is_used_zero_takes_the_default_negative_is_refused():
    assert resolved(goal_time_s=0.5, goal_time_default_s=1.0).goal_time_s == 0.5
    assert resolved(goal_time_s=0.0, goal_time_default_s=1.0).goal_time_s == 1.0
    assert resolved(goal_time_s=0.0, goal_time_default_s=0.0).goal_time_s == 0.0  # no limit
    assert "goal_time_tolerance -0.1 s is negative" in resolve(goal_time_s=-0.1)
    assert "not finite" in resolve(goal_time_s=math.nan)


def test_the_path_check_names_the_joint_outside_its_tolerance_with_its_error():
    tolerances = resolved(path=[("elbow", 0.1, 0.5)], path_rad=0.2)
    zero = np.zeros(3)
    assert tolerances.path_violation(ARM, np.array([0.2, -0.1, 0.0]), zero) is None  # at the bound is within
    assert tolerances.path_violation(ARM, np.array([0.0, -0.15, 0.0]), zero) == (
        "elbow position error -0.15 rad is outside its path tolerance ±0.1 rad"
    )
    assert tolerances.path_violation(ARM, zero, np.array([0.0, 0.6, 0.0])) == (
        "elbow velocity error +0.6 rad/s is outside its path tolerance ±0.5 rad/s"
    )
    # Where no velocity tolerance is in force, any velocity error is within.
    assert tolerances.path_violation(ARM, zero, np.array([50.0, 0.0, -50.0])) is None


def test_the_goal_check_is_none_when_reached_and_names_the_joint_still_outside():
    tolerances = resolved(goal=[("wrist", 0.01, 0.0)], goal_rad=0.02)
    assert tolerances.goal_miss(ARM, np.array([0.019, -0.02, 0.009]), np.zeros(3)) is None
    assert tolerances.goal_miss(ARM, np.array([0.0, 0.0, 0.03]), np.zeros(3)) == (
        "wrist position error +0.03 rad is outside its goal tolerance ±0.01 rad"
    )
    # No tolerance at all: any error is the goal reached (JTC then succeeds at the trajectory's end).
    assert resolved().goal_miss(ARM, np.array([1.0, -2.0, 3.0]), np.ones(3)) is None
