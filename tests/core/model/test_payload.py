"""The bound on a rated payload's gravity torque, joint by joint."""

import numpy as np
import pytest

from robot_controller.core.model import ArmDynamics
from robot_controller.core.model.payload import RATED_REACH_M, torque_bound
from robot_controller.robots import ROBOTS, urdf_of


def test_a_payload_bound_is_m_g_times_each_joints_lever_plus_the_reach():
    """planar2 stretched along x, both axes along y (gravity along -z): the last link's origin is as far from
    each axis as the links in between are long, and a load may sit RATED_REACH_M further."""
    model = ArmDynamics(urdf_of("planar2")).model
    stretched = torque_bound(model, 2.0, np.zeros(2))
    origin_x = model.body(int(model.jnt_bodyid[1])).pos[0]  # the second joint's link, from the first's
    assert stretched == pytest.approx(2.0 * 9.81 * (np.array([origin_x, 0.0]) + RATED_REACH_M), rel=1e-6)
    assert torque_bound(model, 0.0, np.zeros(2)) == pytest.approx([0.0, 0.0])


def test_on_the_panda_the_bound_grows_towards_the_shoulder():
    home = np.array(ROBOTS["panda"].home_position)
    bound = torque_bound(ArmDynamics(urdf_of("panda")).model, 3.0, home)
    assert bound.shape == (7,) and np.all(bound >= 3.0 * 9.81 * RATED_REACH_M - 1e-9)
    assert bound[1] > 4 * bound[6]  # the shoulder carries the load at arm's length, the last wrist at the reach
