"""The controller's arm model linearised over a horizon: where damping or dry friction resists a
joint within a step, a push moves the joint as the model's own steps do, not as a free mass."""

import numpy as np
import pytest

from robot_controller.core.model import ArmDynamics
from robot_controller.robots import urdf_of

# A shoulder and a light wrist with dry friction (1 N·m) and damping (1 N·m·s/rad), like a humanoid's
# wrist in its URDF: both stop the 0.004 kg·m² wrist within a few ms, well inside a 10 ms period.
ARM_WITH_FRICTION = """<robot name="arm">
  <link name="base"/>
  <link name="upper"><inertial><origin xyz="0.15 0 0"/><mass value="2.0"/>
    <inertia ixx="1e-3" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="hand"><inertial><origin xyz="0.03 0 0"/><mass value="0.5"/>
    <inertia ixx="1e-3" iyy="3e-3" izz="3e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="40" velocity="3"/><dynamics damping="1.0" friction="1.0"/></joint>
  <joint name="wrist" type="revolute"><parent link="upper"/><child link="hand"/><axis xyz="0 1 0"/>
    <origin xyz="0.3 0 0"/><limit lower="-3" upper="3" effort="3" velocity="3"/>
    <dynamics damping="1.0" friction="1.0"/></joint>
</robot>"""


@pytest.mark.parametrize("velocity", [[0.0, 0.0], [0.3, -0.5]])
def test_a_push_on_a_joint_with_friction_moves_it_as_the_model_steps_do(tmp_path, velocity):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(ARM_WITH_FRICTION)
    model = ArmDynamics(urdf, step_s=0.001)
    assert model.resists_within_step
    q, v = np.array([0.2, -0.3]), np.array(velocity)
    torque = model.gravity(q) + np.array([0.5, 0.3])
    horizon, n = 0.01, 2
    slopes = model.transition(q, v, torque, horizon, 0.001)
    assert slopes.shape == (2 * n, 3 * n)
    mass, alpha = model.mass_matrix(q), 0.05  # rad/s² pushed on one joint at a time
    base = np.concatenate(model.predict(q, v, torque, horizon))
    for j in range(n):
        pushed = np.concatenate(model.predict(q, v, torque, horizon, external_nm=mass[:, j] * alpha))
        np.testing.assert_allclose(slopes[:, 2 * n + j], (pushed - base) / alpha, rtol=0.1, atol=0.02 * horizon)
    # A free mass would gain horizon·α on the wrist; friction and damping hold it to a fraction of that.
    assert slopes[n + 1, 2 * n + 1] < 0.5 * horizon


def test_an_arm_without_damping_or_friction_within_a_step_keeps_the_state_slopes_alone():
    model = ArmDynamics(urdf_of("planar2"), step_s=0.001)
    assert not model.resists_within_step
    assert model.transition(np.zeros(2), np.zeros(2), np.zeros(2), 0.01, 0.001).shape == (4, 4)
