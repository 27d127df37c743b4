"""The controller's arm model on a chain of joints is MuJoCo's multibody model
of its URDF: mass matrix, inverse dynamics and prediction agree with the
simulated plant, coupling and payload included."""

import numpy as np
import pytest

from robot_controller.core.laws import decoupling_map
from robot_controller.core.model import ArmDynamics, MujocoPlant, Payload
from robot_controller.robots import ROBOTS, urdf_of


@pytest.fixture(params=["one_dof", "planar2", "panda"])
def robot(request):
    return request.param


def random_state(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    return rng.uniform(-0.4, 0.4, n), rng.uniform(-1.0, 1.0, n), rng.uniform(-2.0, 2.0, n)


def test_the_prediction_is_the_plant_to_rounding(robot):
    urdf = urdf_of(robot)
    plant, model = MujocoPlant(urdf), ArmDynamics(urdf)
    home = np.array(ROBOTS[robot].home_position)
    offset, velocity, torque = random_state(len(home))
    plant.reset(home + offset, velocity)
    plant.step(torque, 10)
    predicted = model.predict(home + offset, velocity, torque, 0.01, max_step_s=0.001)
    np.testing.assert_allclose(predicted[0], plant.state()[0], atol=1e-12)
    np.testing.assert_allclose(predicted[1], plant.state()[1], atol=1e-12)


def test_inverse_dynamics_gives_the_acceleration_back(robot):
    model = ArmDynamics(urdf_of(robot))
    home = np.array(ROBOTS[robot].home_position)
    offset, velocity, acceleration = random_state(len(home), seed=5)
    torque = model.torque(home + offset, velocity, acceleration)
    np.testing.assert_allclose(model.acceleration(home + offset, velocity, torque), acceleration, atol=1e-8)


def test_the_panda_mass_matrix_couples_its_joints_and_spans_two_orders_of_magnitude():
    model = ArmDynamics(urdf_of("panda"))
    mass = model.mass_matrix(np.array(ROBOTS["panda"].home_position))
    np.testing.assert_allclose(mass, mass.T, atol=1e-12)
    assert np.all(np.linalg.eigvalsh(mass) > 0)
    diagonal = np.diag(mass)
    assert diagonal.max() / diagonal.min() > 100  # a wrist has a hundredth of a shoulder's inertia
    assert abs(mass[1, 3]) > 0.1  # shoulder and elbow share their links
    # Gravity at the ready pose: joint 4 holds the forearm (about 22 N·m, as the issue measured).
    assert model.gravity(np.array(ROBOTS["panda"].home_position))[3] == pytest.approx(22.0, abs=0.5)


def test_the_step_jacobian_matches_finite_differences_of_the_prediction():
    model = ArmDynamics(urdf_of("planar2"))
    q, v, tau = random_state(2, seed=9)
    jacobian = model.step_jacobian(q, v, tau, 0.001)
    base = np.concatenate(model.predict(q, v, tau, 0.001, max_step_s=0.001))
    for k in range(4):
        bump = np.zeros(4)
        bump[k] = 1e-6
        moved = np.concatenate(model.predict(q + bump[:2], v + bump[2:], tau, 0.001, max_step_s=0.001))
        np.testing.assert_allclose((moved - base) / 1e-6, jacobian[:, k], atol=1e-4)


def test_a_payload_adds_its_weight_on_the_last_link():
    urdf = urdf_of("panda")
    home = np.array(ROBOTS["panda"].home_position)
    bare, loaded = ArmDynamics(urdf), ArmDynamics(urdf, Payload(1.0, (0.0, 0.0, 0.1)))
    extra = loaded.gravity(home) - bare.gravity(home)
    assert extra[0] == pytest.approx(0.0, abs=1e-9)  # joint 1's axis is vertical: gravity has no lever on it
    assert abs(extra[1]) > 1.0  # the shoulder lifts the kilogram at arm's length
    plant = MujocoPlant(urdf, payload=Payload(1.0, (0.0, 0.0, 0.1)))
    plant.reset(home)
    plant.step(loaded.gravity(home), 500)  # the loaded model's gravity holds the loaded plant still
    np.testing.assert_allclose(plant.state()[0], home, atol=1e-9)


def test_decoupled_feedback_gives_each_joint_the_acceleration_its_gains_ask_for():
    model = ArmDynamics(urdf_of("panda"))
    q = np.array(ROBOTS["panda"].home_position)
    mapping = decoupling_map(True, model, q)
    mass = model.mass_matrix(q)
    feedback = np.array([1.0, 0, 0, 0, 0, 0, 0.01])
    asked = feedback / np.diag(mass)  # what each joint's gains are for
    np.testing.assert_allclose(np.linalg.solve(mass, mapping @ feedback), asked, atol=1e-12)
    assert decoupling_map(False, model, q) is None
    assert decoupling_map(True, model, q[:1]) is None  # one joint: none


LIGHT_DAMPED_WRIST = """<robot name="wrist">
  <link name="base"/>
  <link name="hand"><inertial><origin xyz="0 0 0"/><mass value="0.1"/>
    <inertia ixx="1e-4" iyy="1e-4" izz="1.4e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="wrist" type="revolute"><parent link="base"/><child link="hand"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="20" velocity="3"/><dynamics damping="2.0"/></joint>
</robot>"""


def test_with_the_plant_step_the_inverse_dynamics_inverts_that_step(tmp_path):
    # Damping 2 N·m·s/rad stops this 1.4e-4 kg·m² wrist in 0.07 ms, well inside a 1 ms step, which MuJoCo takes
    # implicitly in the damping: one step moves it like (M + h·D)·a, 15 times M·a.
    urdf = tmp_path / "wrist.urdf"
    urdf.write_text(LIGHT_DAMPED_WRIST)
    q, v, a, h = np.array([0.1]), np.array([0.5]), np.array([2.0]), 0.001
    for step_s, reached in ((h, 1.0), (None, 0.065)):
        model = ArmDynamics(urdf, step_s=step_s)
        _, v_next = model.predict(q, v, model.torque(q, v, a), h, max_step_s=h)
        assert (v_next - v)[0] / h == pytest.approx(reached * a[0], rel=0.02)
