"""Sensor, actuator, the URDF model, plant, prediction and feedforward (no ROS)."""

import mujoco
import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.errors import ConfigError, TimingError
from robot_controller.core.laws import FeedforwardMode, feedforward_torque
from robot_controller.core.model import (
    Actuator,
    ArmDynamics,
    JointArmModel,
    MujocoPlant,
    can_collide,
    load_model,
    measure,
    steps_per_period,
)
from robot_controller.core.model.mujoco_model import joint_units
from robot_controller.core.reference import make_trajectory
from robot_controller.robots import urdf_of
from tests.core import configs

URDF = resources.default_urdf()
MASS, LENGTH, DAMPING, G = 1.0, 0.5, 0.1, 9.81
INERTIA = MASS * LENGTH**2 / 3


def test_sensor_noise_is_seeded_and_has_the_configured_spread():
    cfg = configs.sensor(position_noise_std=0.005, velocity_noise_std=0.02)
    q, v = np.zeros(20000), np.zeros(20000)
    a = measure(cfg, q, v, np.random.default_rng(3))
    b = measure(cfg, q, v, np.random.default_rng(3))
    np.testing.assert_array_equal(a[0], b[0])
    assert np.std(a[0]) == pytest.approx(0.005, rel=0.03)
    assert np.std(a[1]) == pytest.approx(0.02, rel=0.03)


def test_sensor_quantisation_and_bias():
    cfg = configs.sensor(position_noise_std=0.0, velocity_noise_std=0.0, position_bias=0.01, quantization=0.004)
    q, _ = measure(cfg, np.array([0.1234]), np.array([0.0]), np.random.default_rng(0))
    assert q[0] == pytest.approx(0.132)


def test_actuator_saturates_and_never_passes_non_finite():
    act = Actuator(np.array([10.0]))
    assert act.apply(np.array([25.0]), 0.01)[0] == 10.0
    assert act.apply(np.array([np.nan]), 0.01)[0] == 0.0
    lagged = Actuator(np.array([10.0]), lag_time_constant_s=0.1)
    assert 0 < lagged.apply(np.array([5.0]), 0.01)[0] < 1.0
    with pytest.raises(ConfigError, match="torque_max"):
        Actuator(np.array([0.0]))


def test_urdf_loads_as_the_reference_arm():
    dyn = ArmDynamics(URDF)
    assert dyn.joint_names == ["joint1"]
    assert dyn.mass_matrix(np.zeros(1))[0, 0] == pytest.approx(INERTIA, rel=1e-6)
    assert dyn.damping[0] == pytest.approx(DAMPING)


@pytest.mark.parametrize("q, v, a", [(0.0, 0.0, 0.0), (0.7, -1.2, 3.0), (-1.4, 2.0, -8.0)])
def test_feedforward_matches_the_analytic_arm_and_mujoco(q, v, a):
    dyn = ArmDynamics(URDF)
    q, v, a = np.array([q]), np.array([v]), np.array([a])
    analytic = INERTIA * a + DAMPING * v + MASS * G * LENGTH / 2 * np.cos(q)
    np.testing.assert_allclose(feedforward_torque(FeedforwardMode.FULL, dyn, q, v, a), analytic, rtol=1e-6)
    np.testing.assert_allclose(
        feedforward_torque(FeedforwardMode.GRAVITY, dyn, q, v, a), MASS * G * LENGTH / 2 * np.cos(q), rtol=1e-6
    )
    assert feedforward_torque(FeedforwardMode.NONE, dyn, q, v, a)[0] == 0.0


def test_plant_follows_the_feedforward_torque():
    """Apply the model's torque for a sine: the simulated arm follows the sine."""
    plant = MujocoPlant(URDF, 0.001)
    dyn = ArmDynamics(URDF)
    traj = make_trajectory("sine", joint_count=1, amplitude=0.5, frequency_hz=0.5)
    p, v, _ = traj.sample(0.0)
    plant.reset(p, v)
    for k in range(1000):
        p, v, a = traj.sample(k * 0.001)
        plant.step(dyn.torque(p, v, a), 1)
    assert abs(plant.state()[0][0] - traj.sample(1.0)[0][0]) < 2e-3


def test_timing_ratio_must_be_whole():
    assert steps_per_period(0.001, 0.01) == 10
    with pytest.raises(TimingError):
        steps_per_period(0.001, 0.0105)


def test_prediction_through_the_model_matches_the_plant():
    plant = MujocoPlant(URDF, 0.001)
    dyn = ArmDynamics(URDF)
    plant.reset(np.array([0.3]), np.array([1.0]))
    torque = np.array([4.0])
    q, v = dyn.predict(*plant.state(), torque, 0.02)
    plant.step(torque, 20)
    np.testing.assert_allclose(q, plant.state()[0], atol=5e-4)  # well under the 5 mrad sensor noise
    np.testing.assert_allclose(v, plant.state()[1], atol=1e-2)


def test_the_joint_model_over_the_urdf_steps_a_batch_as_mujoco():
    dyn = ArmDynamics(URDF)
    model = JointArmModel.over_urdf(dyn)
    assert model.inertia[0] == pytest.approx(INERTIA) and model.gravity_torque[0] == pytest.approx(
        MASS * G * LENGTH / 2
    )
    plant = MujocoPlant(URDF, 0.001)
    plant.reset(np.array([0.4]), np.array([-0.5]))
    q, v = np.full((3, 1), 0.4), np.full((3, 1), -0.5)  # a batch of three arms
    for k in range(2000):
        # gravity held, plus a push that swings the arm well inside the joint limits
        torque = model.torque(plant.state()[0], np.zeros(1), np.zeros(1)) + 0.3 * np.sin(0.005 * k)
        plant.step(torque, 1)
        q, v = model.steps(q, v, np.full((3, 1), torque[0]), 0.001, 1)
    assert abs(plant.state()[0][0] - 0.4) > 0.2  # it really moved
    np.testing.assert_allclose(q[:, 0], plant.state()[0][0], atol=1e-9)
    np.testing.assert_allclose(
        model.torque(np.array([0.7]), np.array([1.0]), np.array([2.0])),
        dyn.torque(np.array([0.7]), np.array([1.0]), np.array([2.0])),
        rtol=1e-9,
    )


def test_contacts_are_disabled_only_where_none_can_happen():
    """The reference arm has no geom that can touch another: its models skip MuJoCo's collision
    pass, and move exactly as with it, through the joint's limits and a brake."""
    assert not can_collide(load_model(resources.default_urdf()))
    assert can_collide(load_model(urdf_of("panda")))  # collision meshes: as MuJoCo has it
    skipping, colliding = MujocoPlant(resources.default_urdf()), MujocoPlant(resources.default_urdf())
    assert skipping.model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    colliding.model.opt.disableflags = 0
    for k in range(600):
        torque = np.array([10.0 if k < 300 else -10.0])  # into both ends of the joint's range
        if k == 500:
            for plant in (skipping, colliding):
                plant.set_brakes(np.array([True]), 50.0)
        skipping.step(torque, 10)
        colliding.step(torque, 10)
        assert [x.tolist() for x in skipping.state()] == [x.tolist() for x in colliding.state()]


def test_each_joint_has_its_unit_from_its_type():
    assert joint_units(load_model(urdf_of("planar2"))) == ["rad", "rad"]
    assert joint_units(load_model(urdf_of("scara"))) == ["rad", "rad", "m"]  # the quill slides
