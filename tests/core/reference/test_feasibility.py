"""Feasible trajectories (no ROS): the torque a path needs from the arm's
inverse dynamics, against the actuator's limit less the margin kept for
feedback; the time scale that makes it fit; the chirp's turns, which it can
follow; and the whole-configuration check that refuses, scales or only warns,
on the controller's arm model."""

import re

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import ArmDynamics, JointArmModel
from robot_controller.core.reference import (
    Chirp,
    MinTimeStep,
    Sine,
    check_feasibility,
    make_trajectory,
    peak_torque,
    plan_trajectory,
    time_scaled,
)
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import arm_model


@pytest.fixture(scope="module")
def arm():
    return ArmDynamics(resources.default_urdf())


def fast_chirp():
    """1 rad from 0.5 to 3 Hz: about 30 N·m at the end of its sweep on the reference arm."""
    return make_trajectory(
        "chirp", joint_count=1, amplitude=1.0, frequency_hz=0.5, end_frequency_hz=3.0, sweep_time_s=10.0
    )


def test_the_default_sine_is_feasible_and_left_as_it_is(arm):
    planner = cfg.load_stack()["trajectory_planner"]
    sine = make_trajectory(planner["mode"], **cfg.trajectory_kwargs(planner))
    plan = plan_trajectory(
        sine,
        arm,
        planner["torque_max"],
        margin=planner["feasibility_margin"],
        policy=planner["feasibility"],
        what="sine",
    )
    assert plan.trajectory is sine and plan.warning is None
    result = plan.result
    assert result.feasible and result.scale == 1.0
    # Gravity with the arm horizontal (2.45 N·m) plus damping at full speed: about 2.9 N·m of 8 usable.
    assert 2.7 < result.peak_torque_nm[0] < 3.1
    assert result.usable_nm[0] == pytest.approx(8.0) and result.limit_nm[0] == 10.0


def test_a_fast_chirp_is_infeasible_and_its_scale_factor_brings_it_within_the_usable_torque(arm):
    chirp = fast_chirp()
    result = check_feasibility(chirp, arm, 10.0, 0.2)
    assert not result.feasible and result.fixable
    assert result.peak_torque_nm[0] > 25.0  # inertia 0.0833 kg·m² × (2π·3 Hz)² × 1 rad alone is 29.6 N·m
    k = result.scale
    assert 1.5 < k < 3.0
    slowed = time_scaled(chirp, k)
    assert isinstance(slowed, Chirp)
    assert (slowed.frequency_hz, slowed.end_frequency_hz, slowed.sweep_time_s) == pytest.approx(
        (0.5 / k, 3.0 / k, 10.0 * k)
    )
    # Recomputed on the slowed trajectory itself: within the usable 8 N·m, and not by much.
    peak = peak_torque(slowed, arm)
    assert peak[0] <= 8.0 + 1e-9
    assert peak[0] > 7.8
    assert result.scaled_peak_torque_nm[0] == pytest.approx(peak[0])
    # The smallest factor, to the bisection's tolerance: a little less does not fit.
    assert peak_torque(time_scaled(chirp, k / 1.01), arm)[0] > 8.0


def test_slowing_divides_velocity_by_k_and_acceleration_by_k_squared():
    k = 1.7
    for trajectory in (
        Sine(np.array([1.0]), 0.5, np.array([0.2])),
        Chirp(np.array([0.8]), 0.5, 3.0, 4.0, np.array([0.0])),
        MinTimeStep(np.array([1.0]), 0.0, np.array([0.0]), 60.0),
    ):
        slowed = time_scaled(trajectory, k)
        for t in np.linspace(0.0, 0.4, 9):
            q, v, a = trajectory.sample(t)
            qs, vs, as_ = slowed.sample(k * t)
            np.testing.assert_allclose(qs, q, atol=1e-9)
            np.testing.assert_allclose(vs, v / k, atol=1e-9)
            np.testing.assert_allclose(as_, a / k**2, atol=1e-9)
    assert time_scaled(make_trajectory("hold", joint_count=1), 3.0).sample(1.0)[0][0] == 0.0


def test_a_shaped_step_too_fast_for_the_arm_gets_a_lower_max_acceleration(arm):
    step = make_trajectory(
        "step",
        joint_count=1,
        amplitude=2.0,
        step_time_s=0.5,
        step_shaping="min_time",
        max_acceleration=90.0,
        sample_period_s=0.01,
    )
    plan = plan_trajectory(step, arm, 10.0, what="step")
    assert not plan.result.feasible and plan.result.scale > 1.0
    assert isinstance(plan.trajectory, MinTimeStep)
    assert plan.trajectory.max_acceleration == pytest.approx(90.0 / plan.result.scale**2)
    assert peak_torque(plan.trajectory, arm)[0] <= 8.0 + 1e-9
    assert "max_acceleration 90→" in plan.warning


def test_the_default_step_experiment_fits_as_it_is(arm):
    for amplitude in (0.5, 1.0):
        step = make_trajectory(
            "step",
            joint_count=1,
            amplitude=amplitude,
            step_time_s=0.5,
            step_shaping="min_time",
            max_acceleration=60.0,
            sample_period_s=0.01,
        )
        assert check_feasibility(step, arm, 10.0).feasible


def test_gravity_alone_beyond_the_usable_torque_cannot_be_fixed_by_slowing(arm):
    # q = 0 holds the reference arm horizontal: 2.45 N·m of gravity against 0.8 usable.
    hold = make_trajectory("hold", joint_count=1, offset=0.0)
    result = check_feasibility(hold, arm, 1.0)
    assert not result.feasible and not result.fixable and result.scale == float("inf")
    assert result.gravity_nm[0] == pytest.approx(2.4525, abs=1e-3)
    for policy in ("scale", "refuse"):
        with pytest.raises(ConfigError, match="no slowing reduces"):
            plan_trajectory(hold, arm, 1.0, policy=policy, what="hold")
    assert "no slowing reduces" in plan_trajectory(hold, arm, 1.0, policy="ignore", what="hold").warning
    # Near vertical (1.5 rad) the same arm needs 0.17 N·m: it fits.
    assert check_feasibility(make_trajectory("hold", joint_count=1, offset=1.5), arm, 1.0).feasible
    # A sine whose positions need more than the limit in gravity alone: slowing is no fix either.
    assert not check_feasibility(make_trajectory("sine", joint_count=1), arm, 1.0).fixable


def test_ignore_keeps_the_trajectory_and_warns(arm):
    chirp = fast_chirp()
    plan = plan_trajectory(chirp, arm, 10.0, policy="ignore", what="chirp")
    assert plan.trajectory is chirp and "feasibility: ignore" in plan.warning


def test_scale_warns_once_with_the_numbers_and_the_factor(arm):
    plan = plan_trajectory(fast_chirp(), arm, 10.0, policy="scale", what="chirp")
    assert "\n" not in plan.warning
    assert re.search(
        r"^the chirp needs \d+\.\d N·m on joint1 against 8\.0 N·m usable \(10\.0 N·m limit, "
        r"20 % kept for feedback\): scaled in time ×\d\.\d\d: frequencies 0\.5→0\.\d+ Hz",
        plan.warning,
    )


def chirp_params(**planner):
    params = cfg.load_stack()
    params["trajectory_planner"].update(mode="chirp", frequency_hz=0.5, end_frequency_hz=3.0, **planner)
    return params


def test_refuse_is_a_config_error_with_the_numbers():
    with pytest.raises(ConfigError) as info:
        consistency.check_stack(chirp_params(feasibility="refuse"))
    message = str(info.value)
    assert "\n" not in message
    assert re.fullmatch(
        r"trajectory_planner: the chirp needs \d\d\.\d N·m on joint1 against 8\.0 N·m usable "
        r"\(10\.0 N·m limit, 20 % kept for feedback\); slow it down \(feasibility: scale\) "
        r"or lower the amplitude",
        message,
    ), message


def test_scale_and_ignore_pass_the_whole_configuration_check():
    consistency.check_stack(chirp_params(feasibility="scale"))
    consistency.check_stack(chirp_params(feasibility="ignore"))
    consistency.check_stack(cfg.load_stack())  # the default sine


def test_the_margin_is_the_planners_parameter():
    # 1 rad at 0.5 Hz needs about 2.9 N·m: it fits in half of 10 N·m, not in a tenth (gravity alone is 2.45).
    params = cfg.load_stack()
    params["trajectory_planner"].update(feasibility="refuse", feasibility_margin=0.5)
    consistency.check_stack(params)
    params["trajectory_planner"]["feasibility_margin"] = 0.9
    with pytest.raises(ConfigError, match=r"against 1\.0 N·m usable \(10\.0 N·m limit, 90 % kept for feedback\)"):
        consistency.check_stack(params)
    with pytest.raises(ConfigError, match="feasibility_margin: must be <= 0.9"):
        cfg.spec_of("trajectory_planner", "feasibility_margin").validate(0.95)


def test_the_planner_must_check_against_the_motors_limit_and_the_controllers_arm(tmp_path):
    params = cfg.load_stack()
    params["motor_node"]["torque_max"] = [8.0]
    with pytest.raises(
        ConfigError, match=r"trajectory_planner: torque_max \[10\.0\] N·m differs from " r"motor_node's \[8\.0\] N·m"
    ):
        consistency.check_stack(params)
    params["trajectory_planner"]["torque_max"] = [8.0]
    consistency.check_stack(params)
    copy = tmp_path / "arm.urdf"
    copy.write_text(resources.default_urdf().read_text())
    params["trajectory_planner"]["urdf_path"] = str(copy)
    with pytest.raises(
        ConfigError,
        match=f"trajectory_planner: urdf_path '{copy}' differs from pid_controller's " r"'\(reference arm\)'",
    ):
        consistency.check_stack(params)
    params["trajectory_planner"]["urdf_path"] = str(resources.default_urdf())  # the same file, named
    consistency.check_stack(params)


def test_a_torque_limit_set_for_every_node_reaches_the_planner(tmp_path):
    path = tmp_path / "limit.yaml"
    path.write_text("/**:\n  ros__parameters:\n    torque_max: [6.0]\n")
    params = cfg.load_stack("default", [path])
    assert params["trajectory_planner"]["torque_max"] == [6.0]
    consistency.check_stack(params)


@pytest.mark.parametrize(
    "chirp",
    [
        fast_chirp(),  # 10 s × (0.5 + 3) Hz is 35 whole cycles: the old wrap kept the position, not the velocity
        Chirp(np.array([0.8]), 0.1, 0.5, 4.0, np.array([0.3])),  # 2.4 cycles: the old wrap jumped 0.76 rad too
        Chirp(np.array([0.5]), 2.0, 0.5, 3.0, np.array([0.0])),  # sweeping down first
    ],
)
def test_the_chirp_runs_on_without_a_jump_where_one_sweep_turns_into_the_next(chirp):
    f0, f1, sweep = chirp.frequency_hz, chirp.end_frequency_hz, chirp.sweep_time_s
    amplitude = chirp.amplitude[0]
    # The first sweep is the chirp as it was: offset + A·sin(2π(f0·t + ½·k·t²)).
    k = (f1 - f0) / sweep
    for t in np.linspace(0.0, sweep, 37, endpoint=False):
        expected = chirp.offset[0] + amplitude * np.sin(2.0 * np.pi * (f0 * t + 0.5 * k * t * t))
        assert chirp.sample(t)[0][0] == pytest.approx(expected, abs=1e-12)
    eps = 1e-9
    for turn in range(1, 6):
        (q0, v0, a0), (q1, v1, a1) = chirp.sample(turn * sweep - eps), chirp.sample(turn * sweep + eps)
        assert abs(q1[0] - q0[0]) < 1e-6 and abs(v1[0] - v0[0]) < 1e-5, (turn, q0, q1, v0, v1)
        # Only the sweep-rate term A·2π·k·cos(phase) of the acceleration changes sign: a finite step.
        assert abs(a1[0] - a0[0]) <= 2.0 * amplitude * 2.0 * np.pi * abs(k) + 1e-3
    # After the turn the frequency goes back: half a second either side of it, it is f1 − k/2
    # (position A·sin(phase) and velocity A·2π·f·cos(phase) put together give back A at that f only).
    w = 2.0 * np.pi * (f1 - 0.5 * k)
    for t in (sweep - 0.5, sweep + 0.5):
        q, v, _ = chirp.sample(t)
        assert np.hypot(q[0] - chirp.offset[0], v[0] / w) == pytest.approx(amplitude, rel=1e-9)


def test_the_check_covers_the_chirp_where_its_sweeps_turn(arm):
    # The slowed chirp, as a controller sees it: positions only, differentiated numerically
    # across its first three turns. The torque that asks of the arm stays within what the
    # check found (8 N·m usable); a jump at a turn would ask for thousands of N·m.
    chirp = make_trajectory(
        "chirp", joint_count=1, amplitude=1.0, frequency_hz=0.5, end_frequency_hz=3.0, sweep_time_s=4.5
    )
    plan = plan_trajectory(chirp, arm, 10.0, what="chirp")
    slowed = plan.trajectory
    assert isinstance(slowed, Chirp) and plan.result.scale > 1.5
    h = 1e-3
    worst = 0.0
    for turn in (1, 2, 3):
        for t in turn * slowed.sweep_time_s + np.arange(-0.05, 0.05, h / 3):
            q0, q1, q2 = (slowed.sample(t + d)[0] for d in (-h, 0.0, h))
            torque = arm.torque(q1, (q2 - q0) / (2 * h), (q2 - 2 * q1 + q0) / h**2)
            worst = max(worst, abs(float(torque[0])))
    assert 5.0 < worst <= 8.0 * 1.01, worst
    # And the check's window (a sweep up and one back down) sees what four sweeps need, to the sampling.
    dense = np.linspace(0.0, 4 * slowed.sweep_time_s, 20000)
    needed = max(abs(float(arm.torque(*slowed.sample(t))[0])) for t in dense)
    assert needed <= plan.result.scaled_peak_torque_nm[0] * 1.001


def test_the_check_before_start_uses_the_controllers_arm_model_when_it_has_one():
    params = cfg.load_stack()
    params["trajectory_planner"]["feasibility"] = "refuse"
    consistency.check_stack(params)  # the default sine on the URDF: 2.9 N·m of 8 usable
    # The controller's model: 12 times the URDF's inertia (0.0833 kg·m²); π² rad/s² × 1 kg·m² alone is 9.9 N·m.
    params["pid_controller"]["model_inertia"] = [1.0]
    with pytest.raises(
        ConfigError, match=r"^trajectory_planner: the sine needs 1\d\.\d N·m on joint1 against 8\.0 N·m usable"
    ):
        consistency.check_stack(params)
    # Under scale it passes, slowed as that arm needs.
    params["trajectory_planner"]["feasibility"] = "scale"
    consistency.check_stack(params)
    plan = consistency.trajectory_plan(params)
    model = arm_model(params["pid_controller"])
    assert isinstance(model, JointArmModel) and plan.result.scale > 1.2
    assert isinstance(plan.trajectory, Sine) and plan.trajectory.frequency_hz < 0.45
    assert 7.8 < peak_torque(plan.trajectory, model)[0] <= 8.0 + 1e-9
    # Gravity from the model that no slowing removes: refused under scale too.
    params["pid_controller"]["model_gravity_torque"] = [9.0]
    with pytest.raises(ConfigError, match=r"holding its positions alone needs 9\.0 N·m on joint1 \(gravity\)"):
        consistency.check_stack(params)


def test_a_lighter_controller_model_lets_through_what_the_urdf_would_refuse():
    params = chirp_params(feasibility="refuse")  # 30 N·m on the URDF against 8 usable
    with pytest.raises(ConfigError, match="the chirp needs"):
        consistency.check_stack(params)
    # 0.005 kg·m²: (2π·3 Hz)² × 1 rad × 0.005 is 1.8 N·m, with 2.45 of gravity and 1.9 of damping.
    params["pid_controller"]["model_inertia"] = [0.005]
    consistency.check_stack(params)
    plan = consistency.trajectory_plan(params)
    assert plan.warning is None and plan.result.peak_torque_nm[0] < 8.0


def test_a_sine_faster_than_a_joints_urdf_velocity_limit_is_slowed_naming_the_joint(tmp_path):
    from robot_controller.parameters import consistency

    path = tmp_path / "fast.yaml"
    path.write_text("trajectory_planner:\n  ros__parameters:\n    frequency_hz: 1.5\n")
    params = cfg.load_stack(robot="panda", config=path)
    plan = consistency.trajectory_plan(params)
    assert "panda_joint7 at 5.32 rad/s, beyond its URDF velocity limit 2.61 rad/s" in plan.warning
    assert plan.trajectory.frequency_hz == pytest.approx(0.69, abs=0.01)
    params["trajectory_planner"]["feasibility"] = "refuse"
    with pytest.raises(ConfigError, match="trajectory_planner: the sine needs"):
        consistency.trajectory_plan(params)
    params["trajectory_planner"]["frequency_hz"] = 0.8  # torque fits; the wrist's speed does not
    with pytest.raises(ConfigError, match="panda_joint7 at 3.02 rad/s, beyond its URDF velocity limit"):
        consistency.trajectory_plan(params)


def test_a_path_leaving_a_joints_range_is_refused_under_every_policy(arm):
    sine = make_trajectory("sine", joint_count=1, amplitude=1.0, offset=2.5, frequency_hz=0.1)
    for policy in ("scale", "refuse", "ignore"):
        with pytest.raises(ConfigError, match=r"reaches \[1\.5, 3\.5\] rad on joint1, beyond its limits \[-3, 3\]"):
            plan_trajectory(sine, arm, 1e4, policy=policy, position_range=(np.array([-3.0]), np.array([3.0])))
    within = plan_trajectory(sine, arm, 1e4, position_range=(np.array([-3.0]), np.array([3.6])))
    assert within.trajectory is sine
