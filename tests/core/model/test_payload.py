"""The bounds on a rated payload's gravity torque and inertia, joint by joint."""

import numpy as np
import pytest

from robot_controller.core.model import ArmDynamics
from robot_controller.core.model.payload import RATED_REACH_M, Payload, inertia_bound, torque_bound
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


def test_the_inertia_bound_is_what_a_load_at_the_reach_adds_where_it_moves_most():
    """On the Panda's last joint the link's origin is on its axis: 3 kg RATED_REACH_M off the axis adds m·reach²
    (and the sphere's own 2/5·m·r²), as a model carrying that load has; no load within the reach adds more."""
    home = np.array(ROBOTS["panda"].home_position)
    own = np.diag(ArmDynamics(urdf_of("panda")).mass_matrix(home))
    bound = inertia_bound(ArmDynamics(urdf_of("panda")).model, 3.0, home)
    assert bound[6] == pytest.approx(3.0 * RATED_REACH_M**2, rel=1e-9)
    for place in [(RATED_REACH_M, 0.0, 0.0), (0.0, RATED_REACH_M, 0.0), (0.0, 0.0, RATED_REACH_M)]:
        load = Payload(3.0, place)
        added = np.diag(ArmDynamics(urdf_of("panda"), load).mass_matrix(home)) - own
        assert np.all(added <= bound + load.inertia_kgm2 + 1e-9)
        if place[2] == 0.0:  # off the last axis
            assert added[6] == pytest.approx(bound[6] + load.inertia_kgm2, rel=1e-6)
