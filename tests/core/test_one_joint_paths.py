"""The one-joint float paths (PID, Kalman filter, arm model, actuator, plant, sensor,
sine, re-acquisition blend) give what their array paths give, to rounding, in every mode; and the collision
pass skipped where no contact can happen changes nothing (no ROS)."""

import mujoco
import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.arrays import matrix_power
from robot_controller.core.controller.safe_motion import _quintic
from robot_controller.core.estimation.estimator import JointKalmanFilter, KalmanConfig, _power_2x2
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource, Pid, PidConfig
from robot_controller.core.model.actuator import Actuator
from robot_controller.core.model.plant import ArmDynamics, MujocoPlant, can_collide, load_model
from robot_controller.core.model.sensor_model import SensorConfig, measure
from robot_controller.core.reference.trajectory import Sine
from robot_controller.robots import urdf_of


@pytest.mark.parametrize("anti_windup", list(AntiWindup))
@pytest.mark.parametrize("source", list(DerivativeSource))
@pytest.mark.parametrize("options", [{}, {"derivative_filter_time_s": 0.02, "slew_rate_limit": 200.0}])
def test_one_joint_pid_is_the_array_pid(anti_windup, source, options):
    config = PidConfig(
        kp=[40.0],
        ki=[15.0],
        kd=[3.0],
        output_limit=[4.0],
        integral_limit=[0.05],
        anti_windup=anti_windup,
        derivative_source=source,
        **options,
    )
    one, batch = Pid(config), Pid(config)  # batch: the same joint as a batch of one, (1, 1), on arrays
    rng = np.random.default_rng(3)
    for k in range(300):
        r, rv, y, yv = rng.normal(0.0, [0.3, 2.0, 0.3, 2.0])
        ff = float(rng.normal(0.0, 2.0)) if k % 2 else np.array([rng.normal(0.0, 2.0)])
        if k == 100:
            r = np.nan  # a non-finite input: zero command, state untouched
        a = one.step(0.01, np.array([r]), np.array([rv]), np.array([y]), np.array([yv]), ff)
        b = batch.step(0.01, np.array([[r]]), np.array([[rv]]), np.array([[y]]), np.array([[yv]]), ff)
        for name in ("command", "p", "i", "d", "feedforward", "saturated"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name).reshape(1), rtol=1e-12, atol=1e-15)
        assert a.command.shape == (1,)


@pytest.fixture(scope="module")
def dynamics() -> ArmDynamics:
    return ArmDynamics(resources.default_urdf())


def test_one_joint_dynamics_is_the_arm_model(dynamics):
    """The arm model's float calls give its array calls' numbers (the mass matrix: to rounding, at any q)."""
    one = dynamics.one_joint
    for q, v, tau, ext in [(0.3, -1.2, 2.5, None), (-2.0, 4.0, 30.0, 1.5), (1.0, 0.0, -12.0, -0.2)]:
        array = dynamics.predict(
            np.array([q]), np.array([v]), np.array([tau]), 0.01, 0.001, None if ext is None else np.array([ext])
        )
        assert one.predict(q, v, tau, 0.01, 0.001, ext) == (array[0].item(), array[1].item())
        slopes = dynamics.step_jacobian(np.array([q]), np.array([v]), np.array([tau]), 0.001)
        assert one.step_slopes(q, v, tau, 0.001) == slopes.ravel().tolist()
        assert one.torque(q, v, 3.0) == dynamics.torque(np.array([q]), np.array([v]), np.array([3.0])).item()
        assert one.mass == pytest.approx(dynamics.mass_matrix(np.array([q]))[0, 0], rel=1e-13)


@pytest.mark.parametrize("observer", [False, True])
@pytest.mark.parametrize("timing_s", [0.0, 0.01])
@pytest.mark.parametrize("model_on_floats", [False, True])
def test_one_joint_filter_is_the_array_filter(dynamics, observer, timing_s, model_on_floats):
    """Through agreement, a push (a jump), disagreement and a reading beyond any torque (a restart);
    the arm model asked through its array calls or its float ones (``ArmDynamics.one_joint``)."""

    def make(one_joint=None):
        return JointKalmanFilter(
            KalmanConfig(command_timing_uncertainty_s=timing_s),
            1,
            dynamics.predict,
            jacobian=dynamics.step_jacobian,
            estimate_disturbance=observer,
            mass_matrix=dynamics.mass_matrix,
            disturbance_limit=np.array([10.0]),
            torque_scale=np.array([1.5]),
            one_joint=one_joint,
        )

    floats, arrays = make(dynamics.one_joint if model_on_floats else None), make()
    rng = np.random.default_rng(5)
    q, v, torque = np.zeros(1), np.zeros(1), np.zeros(1)
    for k in range(400):
        t = 0.01 * k
        push = 3.0 if 150 <= k < 250 else 0.0
        q, v = dynamics.predict(q, v, torque, 0.01, 0.001, external_nm=np.array([push]))
        if k == 320:
            v = v + 40.0  # beyond any torque within the limit
        reading = (q + rng.normal(0.0, 0.005, 1), v + rng.normal(0.0, 0.02, 1))
        if 260 <= k < 300:
            reading = (reading[0] + 0.05 * (k - 260) / 40, reading[1])  # readings the model does not explain
        change = np.abs(rng.normal(0.0, 1.0, 1))
        a = floats.update(t, *reading, torque, change)
        b = arrays._update_joints(t, *reading, torque, change)
        # Rounding (products summed in another order), which readings far from the model amplify.
        np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(floats.x, arrays.x, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(floats.P, arrays.P, rtol=1e-6, atol=1e-10)
        np.testing.assert_allclose(floats._distance_sq_average, arrays._distance_sq_average, rtol=1e-6)
        at_instant = (floats.velocity_at_instant(*a, torque), arrays.velocity_at_instant(*a, torque))
        np.testing.assert_allclose(*at_instant, rtol=1e-6, atol=1e-7)
        torque = np.array([2.0 * np.sin(0.02 * k)])
    assert floats.jump_count[0] == arrays.jump_count[0] and floats.restart_count[0] == arrays.restart_count[0]
    if observer:
        assert floats.jump_count[0] >= 1 and floats.restart_count[0] >= 1


@pytest.mark.parametrize("lag_s", [0.0, 0.05])
def test_one_joint_actuator_is_the_array_actuator(lag_s):
    """Saturation, a non-finite command and the lag, on floats as on arrays."""
    one, batch = Actuator(np.array([4.0]), lag_s), Actuator(np.array([4.0]), lag_s)
    for command in (1.5, -7.0, np.nan, np.inf, 3.9, 12.0):
        a = one.apply(np.array([command]), 0.01)
        b = batch.apply(np.array([[command]]), 0.01)  # (1, 1): the array path
        assert a.shape == (1,) and a.tolist() == b.reshape(1).tolist()
        assert one.applied.tolist() == batch.applied.reshape(1).tolist()


def test_one_joint_plant_step_is_the_array_step():
    """The free, undisturbed one-joint step on floats moves the arm as the array step does."""
    urdf = resources.default_urdf()
    one, other = MujocoPlant(urdf), MujocoPlant(urdf)
    for torque in (3.0, -25.0, 0.5):
        one.step(np.array([torque]), 10)
        other.step(np.array([[torque]]).reshape(1).tolist(), 10)  # a list: the array path
        assert [x.tolist() for x in one.state()] == [x.tolist() for x in other.state()]
        assert one.applied_torque.tolist() == other.applied_torque.tolist()


@pytest.mark.parametrize("config", [SensorConfig(), SensorConfig(position_bias=0.01, quantization=0.001)])
def test_one_joint_reading_is_the_array_reading(config):
    """The same draws and sums on floats: the same readings."""
    one, other = np.random.default_rng(3), np.random.default_rng(3)
    for k in range(200):
        q, v = np.array([np.sin(0.1 * k)]), np.array([np.cos(0.3 * k)])
        a = measure(config, q, v, one)
        b = measure(config, q.reshape(1, 1), v.reshape(1, 1), other)  # (1, 1): the array path
        assert [x.tolist() for x in a] == [x.reshape(1).tolist() for x in b]


def test_one_joint_sine_is_the_array_sine():
    one = Sine(np.array([0.7]), 0.5, np.array([0.2]))
    other = Sine(np.array([[0.7]]), 0.5, np.array([[0.2]]))  # (1, 1): the array path
    for t in np.arange(0.0, 3.0, 0.013).tolist():
        assert [x.tolist() for x in one.sample(t)] == [x.reshape(1).tolist() for x in other.sample(t)]


def test_one_joint_blend_is_the_array_blend():
    p0, v0 = np.array([0.3]), np.array([-1.2])
    for tau in np.arange(-0.05, 0.5, 0.0107).tolist():  # before, during and after the 0.4 s blend
        column = np.array([[tau]])  # a column of times: the array path
        for one, array in zip(_quintic(p0, v0, 0.4, tau), _quintic(p0, v0, 0.4, column), strict=True):
            np.testing.assert_allclose(one, array.reshape(1), rtol=1e-13, atol=1e-15)


def test_power_of_a_2x2_on_floats_is_matrix_power():
    rng = np.random.default_rng(0)
    for k in range(1, 25):
        a = rng.normal(size=(2, 2))
        np.testing.assert_allclose(_power_2x2(a.ravel().tolist(), k), matrix_power(a, k).ravel(), rtol=1e-12)


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
