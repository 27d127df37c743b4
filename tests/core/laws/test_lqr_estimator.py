"""LQR design and the Kalman filter (no ROS)."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.controller import law_config
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import JointKalmanFilter
from robot_controller.core.laws import lqr, robustness
from robot_controller.core.model import ArmDynamics, MujocoPlant, measure
from tests.core import configs

INERTIA, DAMPING, DT = 1.0 / 12.0, 0.1, 0.01


@pytest.mark.parametrize("q, r", [((1e4, 1e4, 1.0), 1e-2), ((1.0, 100.0, 1.0), 1.0), ((1.0, 1e3, 0.0), 1e-3)])
def test_lqr_gain_stabilises_the_discretised_arm(q, r):
    design = lqr.design(INERTIA, DAMPING, DT, np.array(q), r)
    closed = design.A - design.B @ design.K
    assert design.spectral_radius == pytest.approx(np.max(np.abs(np.linalg.eigvals(closed))))
    assert design.spectral_radius < 1.0


def test_a_design_that_leaves_the_integral_unweighted_is_refused():
    # no weight on ∫e: the integrator is not detectable, nothing drives it to zero
    with pytest.raises(ConfigError, match="does not stabilise"):
        lqr.design(INERTIA, DAMPING, DT, np.array([0.0, 1e3, 0.0]), 1e-3)


def test_simulated_lqr_cost_matches_the_riccati_prediction():
    q, r = np.array([1e4, 1e4, 1.0]), 1e-2
    design = lqr.design(INERTIA, DAMPING, DT, q, r)
    x0 = np.array([0.0, 0.05, -0.3])
    x, cost = x0.copy(), 0.0
    for _ in range(5000):
        u = -design.K @ x
        cost += x @ np.diag(q) @ x + r * float(u @ u)
        x = design.A @ x + design.B @ u
    assert cost == pytest.approx(x0 @ design.P @ x0, rel=1e-6)


def test_zero_order_hold_discretisation_matches_integration():
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    x = np.array([0.0, 0.1, 0.5])
    fine = x.copy()
    h = DT / 10_000
    for _ in range(10_000):  # u = 1 N·m held
        fine = fine + h * np.array([fine[1], fine[2], (1.0 - DAMPING * fine[2]) / INERTIA])
    np.testing.assert_allclose(A @ x + B[:, 0], fine, atol=1e-5)


def test_lqr_settings_are_checked():
    with pytest.raises(ConfigError, match="lqr_q"):
        lqr.design(INERTIA, DAMPING, DT, np.array([1.0, -1.0, 1.0]), 1.0)
    with pytest.raises(ConfigError, match="lqr_r"):
        lqr.design(INERTIA, DAMPING, DT, np.array([1.0, 1.0, 1.0]), 0.0)
    with pytest.raises(ConfigError, match="lqr_q: expected 3 values"):
        cfg.spec_of("pid_controller", "lqr_q").validate([1.0, 2.0])


def test_lqr_law_is_a_pid_with_the_designed_gains():
    dynamics = ArmDynamics(resources.default_urdf())
    config = configs.controller(controller_type="lqr", lqr_q=(1e4, 1e4, 1.0), lqr_r=1e-2, control_period_s=DT)
    gains = law_config(config, dynamics, 1)
    design = lqr.design(INERTIA, DAMPING, DT, np.array([1e4, 1e4, 1.0]), 1e-2)
    np.testing.assert_allclose([gains.ki[0], gains.kp[0], gains.kd[0]], design.K[0], rtol=1e-6)
    assert gains.derivative_source.value == "velocity_error"


def test_kalman_velocity_error_is_below_the_raw_readings():
    dynamics = ArmDynamics(resources.default_urdf())
    plant = MujocoPlant(resources.default_urdf(), 0.001)
    sensor = configs.sensor(position_noise_std=0.005, velocity_noise_std=0.02)
    kf = JointKalmanFilter(
        configs.kalman(acceleration_noise_std=2.0), 1, dynamics.predict, transition=dynamics.transition
    )
    rng = np.random.default_rng(1)
    raw_errors, filtered_errors = [], []
    previous_torque = np.zeros(1)
    for k in range(1500):
        q, v = plant.state()
        # Gravity held, a sine on top: the arm swings within its joint limits (at 1.5 N·m
        # it reached the stop, where the test measured the contact instead of the filter).
        torque = dynamics.gravity(q) + 0.5 * np.sin(np.array([2 * np.pi * 0.7 * k * DT]))
        q_meas, v_meas = measure(sensor, q, v, rng)
        q_est, v_est = kf.update(k * DT, q_meas, v_meas, previous_torque)
        previous_torque = torque  # it acts until the next reading
        if k > 100:
            raw_errors.append(v_meas[0] - v[0])
            filtered_errors.append(v_est[0] - v[0])
        plant.step(torque, 10)
    assert np.var(filtered_errors) < 0.5 * np.var(raw_errors)
    assert abs(np.mean(filtered_errors)) < 0.01


def test_kalman_settings_are_checked():
    with pytest.raises(ConfigError, match="acceleration_noise_std"):
        configs.kalman(acceleration_noise_std=0.0)


def test_delay_margin_counts_the_periods_of_delay_the_loop_survives():
    one = np.array([[1.0]])
    # x[k+1] = x[k] − k·x[k−d]: k = 1.5 is stable undelayed but not one period late; k = 0.5 is.
    margin = robustness.delay_margin_periods
    assert margin(one, one, np.array([[1.5]]))[0] == 0
    assert margin(one, one, np.array([[0.5]]))[0] >= 1
    assert margin(one, one, np.array([[0.05]]))[0] > margin(one, one, np.array([[0.5]]))[0]
    assert margin(one, one, np.array([[1.5], [0.5], [0.05]])).tolist() == [
        margin(one, one, k)[0] for k in (1.5, 0.5, 0.05)
    ]
