"""Readings of the positions alone, each with its σ and their correlation (a camera's), in the filter (no ROS): a
two-joint arm followed from readings 30 ms apart with the commands between them each over its own span; a joint the
reading says nothing of (σ inf) runs on the model; a late second reading fused at the filter's time pulls the estimate
its way by its weight; a state gone non-finite restarts the filter from the reading; the covariance and the wire's
label say what the vision meant."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.blocks.values import labelled_correlation, labelled_position_std, position_std_label
from robot_controller.core.estimation import JointKalmanFilter
from robot_controller.core.estimation.position_readings import UNMEASURED_STD, position_covariance
from robot_controller.core.model import ArmDynamics
from tests.core import configs

PLANAR2 = resources.share_dir() / "description" / "planar2_arm.urdf"


def arm_filter() -> tuple[ArmDynamics, JointKalmanFilter]:
    dynamics = ArmDynamics(PLANAR2)
    n = len(dynamics.joint_names)
    kf = JointKalmanFilter(
        configs.kalman(),
        n,
        dynamics.predict,
        transition=dynamics.transition,
        estimate_disturbance=True,
        mass_matrix=dynamics.mass_matrix,
        disturbance_limit=np.full(n, 10.0),
    )
    return dynamics, kf


def follow(blind_joint: int | None = None, steps: int = 300, blind_from: int = 100, blind_to: int = 166):
    """The arm under a torque changing every 10 ms, read every 30 ms (σ 2 mrad): the filter's errors."""
    dynamics, kf = arm_filter()
    n = len(dynamics.joint_names)
    rng = np.random.default_rng(2)
    q, v = np.zeros(n), np.zeros(n)
    commands: list[tuple[float, np.ndarray]] = []  # (issued s, N·m)

    def before(t_s: float) -> np.ndarray:
        return next((c for issued, c in reversed(commands) if issued < t_s - 1e-9), np.zeros(n))

    errors = []
    for k in range(steps):
        t = k * 0.01
        if k % 3 == 0:  # a frame: the commands since the last each over its own span, then the reading
            sigma = np.full(n, 0.002)
            if blind_joint is not None and blind_from <= k < blind_to:
                sigma[blind_joint] = np.inf
            if kf.time_s is not None:
                for issued, _ in [c for c in commands if kf.time_s + 1e-9 < c[0] < t - 1e-9]:
                    kf.advance(issued, before(issued))
            reading = q + rng.normal(0, 0.002, n)
            filtered, _ = kf.update(t, reading, np.zeros(n), before(t), noise=(sigma, None))
            errors.append(filtered - q)
        torque = dynamics.torque(q, v, np.zeros(n)) + 0.3 * np.sin(3 * t + np.arange(n))
        commands.append((t, torque))
        q, v = dynamics.predict(q, v, torque, 0.01, 0.001)
    return np.array(errors)


def test_readings_of_positions_alone_a_frame_every_three_commands_are_followed():
    errors = follow()[20:]
    assert np.sqrt(np.mean(errors**2)) < 0.002  # within the readings' own σ


def test_a_joint_no_reading_constrains_for_a_while_runs_on_the_model():
    errors = follow(blind_joint=0)[20:]
    blind = errors[34:56, 0]  # frames 100-166 of the 300 steps: 0.66 s on the model alone
    assert np.isfinite(errors).all() and np.max(np.abs(blind)) < 0.01, np.max(np.abs(blind))
    assert np.sqrt(np.mean(errors[-20:] ** 2)) < 0.004  # found again (within twice the readings' σ)


def test_a_late_second_reading_pulls_the_estimate_by_its_weight_and_a_non_finite_state_restarts():
    _, kf = arm_filter()
    n = kf.joint_count
    kf.update(0.0, np.zeros(n), np.zeros(n), np.zeros(n))
    kf.update(0.01, np.zeros(n), np.zeros(n), np.zeros(n))
    before = kf.x[:, 0].copy()
    sure, _ = kf.correct_position(np.full(n, 0.01), np.full(n, 1e-4))
    assert np.allclose(sure, 0.01, atol=1e-3)  # far surer than the filter: taken nearly as it is
    vague, _ = kf.correct_position(before - 0.01, np.full(n, UNMEASURED_STD))
    assert np.allclose(vague, sure, atol=1e-6)  # says nothing: moves nothing
    kf.P[0, 0, 0] = np.nan  # a model pushed past what it integrates
    restarts = int(np.sum(kf.restart_count))
    with np.errstate(all="ignore"):
        position, _ = kf.update(0.02, np.full(n, 0.3), np.zeros(n), np.zeros(n))
    assert np.allclose(position, 0.3) and int(np.sum(kf.restart_count)) > restarts


def test_the_covariance_and_its_label_say_what_the_vision_meant():
    sigma = np.array([0.002, 0.004, np.inf])
    rho = np.array([[1.0, -0.8, 0.3], [-0.8, 1.0, 0.1], [0.3, 0.1, 1.0]])
    covariance = position_covariance(sigma, rho)
    assert covariance[0, 1] == pytest.approx(-0.8 * 0.002 * 0.004)
    assert covariance[2, 2] == UNMEASURED_STD**2 and covariance[0, 2] == 0.0  # unseen: uncorrelated, huge
    label = position_std_label(sigma, rho)
    np.testing.assert_array_equal(labelled_position_std(label), sigma)
    np.testing.assert_allclose(labelled_correlation(label, 3), rho, atol=1e-4)
    assert labelled_correlation(label.replace("-0.8000", "-1.8000"), 3) is None  # beyond ±1: not a correlation
    assert labelled_correlation("position_std:0.1,0.2;correlation:x", 2) is None
    np.testing.assert_array_equal(labelled_position_std("position_std:0.1,nan,-1"), [0.1, np.inf, np.inf])
