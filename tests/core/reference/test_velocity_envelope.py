"""A robot's speed limits near its position limits (libfranka's, the FR3's), and trajectories kept inside them."""

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.velocity_envelope import FR3_VELOCITY_ENVELOPE as FR3


def test_far_from_its_limits_a_joint_may_go_its_top_speed_and_at_a_limit_not_towards_it():
    middle = (FR3.lower_rad + FR3.upper_rad) / 2
    towards_lower, towards_upper = FR3.speeds(middle)
    assert np.allclose(towards_lower, FR3.max_rad_s) and np.allclose(towards_upper, FR3.max_rad_s)
    towards_lower, towards_upper = FR3.speeds(FR3.upper_rad)
    assert np.all(towards_upper == 0) and np.allclose(towards_lower, FR3.max_rad_s)


def test_the_elbow_near_its_lower_limit_as_libfranka_computes_it():
    q = (FR3.lower_rad + FR3.upper_rad) / 2
    q[3] = FR3.lower_rad[3] + 0.1  # 0.1 rad above the elbow's lower limit
    limit = FR3.limit(q, -np.ones(7))
    assert limit[3] == pytest.approx(np.sqrt(2 * 4.0 * 0.1) - 0.3)  # sqrt(2·deceleration·room) − offset
    assert limit[3] < FR3.max_rad_s[3] / 4


def test_a_sine_faster_than_the_envelope_allows_near_a_limit_is_slowed():
    from robot_controller.core.model import ArmDynamics
    from robot_controller.core.reference import make_trajectory, plan_trajectory
    from robot_controller.robots.description import describe

    n = 7
    panda_dynamics = ArmDynamics(describe("panda").path)
    amplitude = [0.3] * n
    offset = [0.0, 0.0, 0.0, -2.6, 0.0, 1.8, 0.8]  # the elbow's sine comes within 0.15 rad of its limit
    sine = make_trajectory("sine", joint_count=n, amplitude=amplitude, frequency_hz=1.0, offset=offset)
    speeds = np.full(n, 2.0)
    plain = plan_trajectory(sine, panda_dynamics, 87.0, velocity_limit=speeds)
    assert plain.trajectory is sine, "within the constant limits"
    kept = plan_trajectory(sine, panda_dynamics, 87.0, velocity_limit=speeds, envelope=FR3)
    assert "the speed the robot allows it there" in kept.warning and "scaled in time" in kept.warning
    with pytest.raises(ConfigError, match="the speed the robot allows it there"):
        plan_trajectory(sine, panda_dynamics, 87.0, velocity_limit=speeds, envelope=FR3, policy="refuse")
