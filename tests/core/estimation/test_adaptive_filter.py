"""The Kalman filter's three adaptations (no ROS): it trusts its model while
the readings agree with it, takes a reading that stands out among agreeing
ones as a jump of the external torque, moves to follow its readings while
they disagree, and widens its velocity by a command change whose instant is
uncertain (wall clock). Also: its model steps as the MuJoCo plant does."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.controller.tick_state import StateAtTick
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import JointKalmanFilter
from robot_controller.core.model import ArmDynamics, MujocoPlant, measure
from tests.core import configs

DT = 0.01
SENSOR = configs.sensor(position_noise_std=0.005, velocity_noise_std=0.02)


@pytest.fixture(scope="module")
def dynamics() -> ArmDynamics:
    return ArmDynamics(resources.default_urdf())


def observer(dynamics: ArmDynamics, **config) -> JointKalmanFilter:
    return JointKalmanFilter(
        configs.kalman(**config),
        1,
        dynamics.predict,
        transition=dynamics.transition,
        estimate_disturbance=True,
        mass_matrix=dynamics.mass_matrix,
    )


def track(dynamics, kf, seconds, *, push_at_s=None, push_nm=2.0, seed=1, plant_urdf=None):
    """The arm made to follow a sine, read with the scenario's noise; the plant
    pushed from ``push_at_s``. Returns
    per tick (time, estimated disturbance, true q − estimated q, the
    acceleration σ in force)."""
    plant = MujocoPlant(plant_urdf or resources.default_urdf(), 0.001)
    plant.reset(np.zeros(1))
    rng = np.random.default_rng(seed)
    torque = np.zeros(1)
    rows = []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        if push_at_s is not None and abs(t - push_at_s) < 1e-9:
            plant.set_disturbance(np.array([push_nm]), 30.0)
        q_meas, v_meas = measure(SENSOR, *plant.state(), rng)
        q_est, _ = kf.update(t, q_meas, v_meas, torque)
        rows.append((t, kf.disturbance[0], plant.state()[0][0] - q_est[0], np.sqrt(kf._noise_variances()[1][0])))
        # A torque the filter knows: a stiff PD on the TRUE state about a slow sine, with the model's
        # feedforward (the filter only watches; a push moves the arm 2 N·m / 30 N·m/rad off).
        q_true, v_true = plant.state()
        w = 2 * np.pi * 0.5
        r, rd, rdd = 0.5 * np.sin(w * t), 0.5 * w * np.cos(w * t), -0.5 * w * w * np.sin(w * t)
        torque = (
            dynamics.torque(np.array([r]), np.array([rd]), np.array([rdd])) + 30.0 * (r - q_true) + 2.0 * (rd - v_true)
        )
        plant.step(torque, 10)
    return np.array(rows)


def test_the_arm_model_steps_as_mujoco_does(dynamics):
    # Implicit in the damping, as MuJoCo's Euler: the prediction is the plant's to rounding.
    plant = MujocoPlant(resources.default_urdf(), 0.001)
    for q0, v0, tau in [(0.3, 0.0, 2.0), (-0.8, 2.5, -1.0), (1.2, -3.0, 5.0)]:
        plant.reset(np.array([q0]), np.array([v0]))
        plant.step(np.array([tau]), 10)
        q, v = dynamics.predict(np.array([q0]), np.array([v0]), np.array([tau]), 0.01, 0.001)
        assert abs(q[0] - plant.state()[0][0]) < 1e-12 and abs(v[0] - plant.state()[1][0]) < 1e-12


def test_between_pushes_the_filter_trusts_its_model_and_averages_the_noise_away(dynamics):
    trusting = track(dynamics, observer(dynamics), 6.0)
    following = track(dynamics, observer(dynamics, acceleration_noise_std=2.0, disturbance_noise_std=0.3), 6.0)
    rms = [np.sqrt(np.mean(run[200:, 2] ** 2)) for run in (trusting, following)]
    assert rms[0] < 0.8 * rms[1]  # position error, rad: the model's averaging pays
    assert rms[0] < 0.001


def test_a_push_is_taken_as_a_jump_and_followed_within_a_few_periods(dynamics):
    kf = observer(dynamics)
    run = track(dynamics, kf, 3.0, push_at_s=2.0)
    before, after = run[run[:, 0] < 2.0], run[run[:, 0] >= 2.0]
    assert kf.jump_count[0] >= 1
    assert np.max(np.abs(before[100:, 1])) < 0.05  # nothing to estimate, nothing estimated
    assert abs(after[5, 1] - 2.0) < 0.3  # N·m, within 5 periods of the push
    assert abs(np.mean(after[-50:, 1]) - 2.0) < 0.02
    slow = observer(dynamics, jump_detection_sigma=0.0)
    run = track(dynamics, slow, 3.0, push_at_s=2.0)
    assert slow.jump_count[0] == 0 and run[run[:, 0] >= 2.0][5, 1] < 0.5  # without jumps: still far off


def test_noise_alone_makes_no_jump(dynamics):
    kf = observer(dynamics)
    track(dynamics, kf, 10.0, seed=3)
    assert kf.jump_count[0] == 0


def test_readings_that_disagree_move_the_filter_to_follow_them_and_make_no_jumps(dynamics):
    # The heavy arm (4× the inertia, 3× the gravity torque) read by a filter with the reference arm's model.
    kf = observer(dynamics)
    run = track(dynamics, kf, 4.0, plant_urdf=resources.share_dir() / "description" / "heavy_arm.urdf")
    assert np.mean(run[100:, 3] > 1.0) > 0.5  # mostly near the mismatch σ (2 rad/s²), off the trusting 0.005
    # Not one jump a reading: a handful while the disagreement builds up in the average (the first
    # half second: 6), then one in 3.5 s.
    assert kf.jump_count[0] <= 10
    agreeing = track(dynamics, observer(dynamics), 4.0)
    assert np.max(agreeing[100:, 3]) < 0.1  # readings that agree leave it trusting
    assert np.all(np.isfinite(run))


def test_a_command_change_whose_instant_is_uncertain_widens_the_velocity(dynamics):
    def velocity_variance(uncertainty_s: float, change: float) -> float:
        kf = JointKalmanFilter(
            configs.kalman(command_timing_uncertainty_s=uncertainty_s),
            1,
            dynamics.predict,
            transition=dynamics.transition,
            mass_matrix=dynamics.mass_matrix,
        )
        for k in range(50):
            kf.update(k * DT, np.zeros(1), np.zeros(1), dynamics.gravity(np.zeros(1)))
        kf.update(50 * DT, np.zeros(1), np.zeros(1), dynamics.gravity(np.zeros(1)), np.array([change]))
        return kf.joint_covariance[0, 1, 1]

    exact = velocity_variance(0.0, 1.0)
    assert velocity_variance(0.01, 0.0) == pytest.approx(exact)  # no change: nothing uncertain
    assert velocity_variance(0.01, 1.0) > 1.5 * exact
    with pytest.raises(ConfigError, match="command_timing_uncertainty_s"):
        configs.kalman(command_timing_uncertainty_s=-1.0)


def test_the_command_change_over_a_span_is_what_the_controller_issued_in_it():
    state = StateAtTick(1, None, None)
    for t, command in [(0.0, 1.0), (0.01, 1.5), (0.02, 1.5), (0.03, 0.5)]:
        state.remember_command(t, np.array([command]))
    assert state.command_change(0.005, 0.015)[0] == pytest.approx(0.5)
    assert state.command_change(0.015, 0.025)[0] == pytest.approx(0.0)
    assert state.command_change(0.005, 0.035)[0] == pytest.approx(np.hypot(0.5, 1.0))


def test_a_reading_no_torque_within_the_limit_explains_restarts_the_filter(dynamics):
    # A brake that held the moving arm for part of a period: the velocity drops by more than
    # the torque limit could do in a period. Taken as an external torque it would be estimated
    # at the limit and commanded against once the brake has let go; instead the filter starts
    # again from the reading, the external torque back to 0.
    kf = JointKalmanFilter(
        configs.kalman(),
        1,
        dynamics.predict,
        transition=dynamics.transition,
        estimate_disturbance=True,
        mass_matrix=dynamics.mass_matrix,
        disturbance_limit=np.array([10.0]),
    )
    torque = dynamics.gravity(np.zeros(1))
    for k in range(100):  # at rest, horizontal, held by the model's torque
        kf.update(k * DT, np.zeros(1), np.zeros(1), torque)
    q, v = kf.update(100 * DT, np.zeros(1), np.array([-3.0]), torque)  # 3 rad/s gone in one period
    assert kf.restart_count[0] == 1 and kf.disturbance[0] == 0.0
    assert v[0] == -3.0  # the reading, as it is
    q_next, v_next = kf.predict(q, v, torque, DT)
    kf.update(101 * DT, q_next, v_next + 0.06, torque)  # 0.5 N·m's worth: within reach, no restart
    assert kf.restart_count[0] == 1


def test_the_filter_trusts_its_model_in_lockstep_only():
    # On the wall clock a push begins anywhere inside a period and commands reach the drive late:
    # there the filter follows its readings and takes no jumps (a hostile 10 N·m effort for one
    # period, taken as a jump, drove the arm up to 175 mrad off; with these settings 6-12 mrad).
    from robot_controller import parameters as cfg
    from robot_controller.parameters.builders import kalman_config

    values = cfg.load_stack("default")["pid_controller"]
    lockstep = kalman_config(dict(values, lockstep=True))
    wall = kalman_config(dict(values, lockstep=False))
    assert lockstep.acceleration_noise_std == 0.005 and lockstep.jump_detection_sigma == 5.0
    assert lockstep.command_timing_uncertainty_s == 0.0
    assert wall.acceleration_noise_std == 2.0 and wall.disturbance_noise_std == 0.3
    assert wall.jump_detection_sigma == 0.0 and wall.command_timing_uncertainty_s == 0.01
