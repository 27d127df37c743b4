"""Trajectories, sensor, actuator, plant and feedforward (no ROS)."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.errors import ConfigError, TimingError
from robot_controller.core.laws.feedforward import FeedforwardMode, feedforward_torque
from robot_controller.core.model import Actuator, ArmDynamics, MujocoPlant, SensorConfig, measure, steps_per_period
from robot_controller.core.reference import MODES, make_trajectory
from robot_controller.core.validation import check_effort, check_joint_state, check_trajectory

URDF = resources.default_urdf()
MASS, LENGTH, DAMPING, G = 1.0, 0.5, 0.1, 9.81
INERTIA = MASS * LENGTH**2 / 3


@pytest.mark.parametrize("mode", [m for m in MODES if m in ("sine", "chirp")])
def test_smooth_trajectories_are_self_consistent(mode):
    traj = make_trajectory(mode, joint_count=2, amplitude=[1.0, 0.5], frequency_hz=0.5)
    h = 1e-5
    for t in (0.3, 1.7, 4.2):
        p0, v0, a0 = traj.sample(t - h)
        p1, v1, a1 = traj.sample(t + h)
        _, v, a = traj.sample(t)
        np.testing.assert_allclose((p1 - p0) / (2 * h), v, atol=1e-4)
        np.testing.assert_allclose((v1 - v0) / (2 * h), a, atol=1e-3)


def test_sine_reference_values():
    p, v, a = make_trajectory("sine", joint_count=1, amplitude=1.0, frequency_hz=0.5).sample(0.5)
    assert p[0] == pytest.approx(1.0) and v[0] == pytest.approx(0.0, abs=1e-12)
    assert a[0] == pytest.approx(-(np.pi**2))


def test_step_square_hold():
    step = make_trajectory("step", joint_count=1, amplitude=0.5, step_time_s=1.0)
    assert step.sample(0.99)[0][0] == 0.0 and step.sample(1.0)[0][0] == 0.5
    square = make_trajectory("square", joint_count=1, amplitude=0.3, frequency_hz=1.0)
    assert square.sample(0.25)[0][0] == 0.3 and square.sample(0.75)[0][0] == -0.3
    assert make_trajectory("hold", joint_count=1, offset=0.2).sample(7.0)[0][0] == 0.2


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(mode="zigzag"), "mode"),
        (dict(amplitude=[1, 2, 3]), "amplitude"),
        (dict(frequency_hz=float("nan")), "frequency_hz"),
    ],
)
def test_bad_trajectory_names_the_key(kwargs, key):
    args = dict(mode="sine", joint_count=2) | kwargs
    with pytest.raises(ConfigError, match=key):
        make_trajectory(args.pop("mode"), **args)


def test_sensor_noise_is_seeded_and_has_the_configured_spread():
    cfg = SensorConfig(position_noise_std=0.005, velocity_noise_std=0.02)
    q, v = np.zeros(20000), np.zeros(20000)
    a = measure(cfg, q, v, np.random.default_rng(3))
    b = measure(cfg, q, v, np.random.default_rng(3))
    np.testing.assert_array_equal(a[0], b[0])
    assert np.std(a[0]) == pytest.approx(0.005, rel=0.03)
    assert np.std(a[1]) == pytest.approx(0.02, rel=0.03)


def test_sensor_quantisation_and_bias():
    cfg = SensorConfig(position_noise_std=0.0, velocity_noise_std=0.0, position_bias=0.01, quantization=0.004)
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


@pytest.mark.parametrize(
    "names, pos, vel, ok",
    [
        (["joint1"], [0.1], [0.2], True),
        ([], [0.1], [0.2], True),
        (["joint1"], [], [], False),
        (["joint1"], [0.1, 0.2], [0.2], False),
        (["elbow"], [0.1], [0.2], False),
        (["joint1"], [float("nan")], [0.0], False),
        (["joint1"], [0.0], [float("inf")], False),
    ],
)
def test_joint_state_check(names, pos, vel, ok):
    result = check_joint_state(names, pos, vel, ["joint1"])
    assert (not isinstance(result, str)) == ok


def test_trajectory_and_effort_checks():
    assert not isinstance(check_trajectory([0.1, 0.2, 0.3], 1), str)
    p, v, a, sample_time = check_trajectory([0.1, 0.2], 1)  # the tutorial's [position, velocity]
    assert a[0] == 0.0 and sample_time is None
    assert check_trajectory([0.1, 0.2, 0.3, 12.5], 1)[3] == 12.5  # ours: with the sample time
    assert isinstance(check_trajectory([0.1, 0.2, 0.3, float("nan")], 1), str)
    assert isinstance(check_trajectory([0.1], 1), str)
    assert isinstance(check_trajectory([0.1, float("nan"), 0.0], 1), str)
    assert isinstance(check_effort([1.0, 2.0], 1), str)
    assert isinstance(check_effort([float("inf")], 1), str)


def test_analytic_arm_matches_mujoco():
    from robot_controller.core.batch import AnalyticArmBatch, ArmConstants

    dyn = ArmDynamics(URDF)
    constants = ArmConstants.from_dynamics(dyn)
    assert constants.inertia == pytest.approx(INERTIA) and constants.gravity_torque == pytest.approx(
        MASS * G * LENGTH / 2
    )
    plant = MujocoPlant(URDF, 0.001)
    plant.reset(np.array([0.4]), np.array([-0.5]))
    batch = AnalyticArmBatch(constants, batch=3)
    batch.q[:], batch.v[:] = 0.4, -0.5
    for k in range(2000):
        # gravity held, plus a push that swings the arm well inside the joint limits
        torque = constants.torque(plant.state()[0], np.zeros(1), np.zeros(1)) + 0.3 * np.sin(0.005 * k)
        plant.step(torque, 1)
        batch.step(np.full((3, 1), torque[0]), 1)
    assert abs(plant.state()[0][0] - 0.4) > 0.2  # it really moved
    np.testing.assert_allclose(batch.q[:, 0], plant.state()[0][0], atol=1e-9)
    np.testing.assert_allclose(
        constants.torque(np.array([0.7]), np.array([1.0]), np.array([2.0])),
        dyn.torque(np.array([0.7]), np.array([1.0]), np.array([2.0])),
        rtol=1e-9,
    )


def test_min_time_step_reaches_the_target_within_the_acceleration_limit():
    traj = make_trajectory(
        "step", joint_count=1, amplitude=0.5, step_time_s=1.0, step_shaping="min_time", max_acceleration=50.0
    )
    duration = 2 * np.sqrt(0.5 / 50.0)
    assert traj.sample(0.9)[0][0] == 0.0
    assert traj.sample(1.0 + duration / 2)[0][0] == pytest.approx(0.25)
    p, v, a = traj.sample(1.0 + duration + 1e-9)
    assert p[0] == pytest.approx(0.5) and v[0] == pytest.approx(0.0, abs=1e-6) and a[0] == 0.0
    times = np.linspace(0.9, 1.5, 6001)
    samples = np.array([traj.sample(t) for t in times])[:, :, 0]
    assert np.max(np.abs(samples[:, 2])) <= 50.0 and np.all(np.diff(samples[:, 0]) >= -1e-12)
    np.testing.assert_allclose(np.gradient(samples[:, 0], times), samples[:, 1], atol=0.05)
