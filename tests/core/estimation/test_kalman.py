"""The filter's arithmetic: its closed forms and process noise against the formulas they stand
for, and one joint through agreement, a push, disagreement and a reading beyond any torque
(no ROS)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from robot_controller import resources
from robot_controller.core.estimation import JointKalmanFilter, innovation, inverse_2x2, process_noise
from robot_controller.core.model import ArmDynamics, matrix_power
from tests.core import configs


@pytest.mark.parametrize("size", [2, 4, 14])
@pytest.mark.parametrize("k", range(1, 13))
def test_matrix_power_is_numpys_bit_for_bit(size, k):
    a = np.eye(size) + 0.01 * np.random.default_rng(size + k).standard_normal((size, size))
    np.testing.assert_array_equal(matrix_power(a, k), np.linalg.matrix_power(a, k))


def test_inverse_2x2_is_the_inverse():
    rng = np.random.default_rng(0)
    root = rng.standard_normal((50, 2, 2))
    S = root @ root.transpose(0, 2, 1) + 1e-3 * np.eye(2)  # covariances, some badly conditioned
    np.testing.assert_allclose(inverse_2x2(S), np.linalg.inv(S), rtol=1e-9, atol=0)
    np.testing.assert_allclose(inverse_2x2(S[0]), np.linalg.inv(S[0]), rtol=1e-12)


def test_process_noise_is_the_double_integrator_entry_by_entry():
    """The templates' product against the formula written out for each entry."""
    dt, b = 0.01, np.array([2.0, 30.0])
    sigma_d, sigma_a = np.array([1e-4, 0.3]), np.array([5e-3, 2.0])
    Q = process_noise(configs.kalman(), dt, b, sigma_d, sigma_a)
    a2, w = sigma_a**2, sigma_d**2
    expected = np.zeros((2, 3, 3))
    expected[:, 0, 0] = dt**4 / 4 * a2 + w * b * b * dt**5 / 20
    expected[:, 0, 1] = expected[:, 1, 0] = dt**3 / 2 * a2 + w * b * b * dt**4 / 8
    expected[:, 1, 1] = dt**2 * a2 + w * b * b * dt**3 / 3
    expected[:, 0, 2] = expected[:, 2, 0] = w * b * dt**3 / 6
    expected[:, 1, 2] = expected[:, 2, 1] = w * b * dt**2 / 2
    expected[:, 2, 2] = w * dt
    np.testing.assert_allclose(Q, expected, rtol=1e-13, atol=0)


@given(st.lists(st.floats(min_value=0.0, max_value=10.0), min_size=3, max_size=3).map(np.array))
def test_noise_in_force_while_agreeing_is_the_general_formula(average):
    near, far = (1e-4, 5e-3), (0.3, 2.0)
    w = np.clip((average - innovation.MISMATCH_FROM) / innovation.MISMATCH_SPAN, 0.0, 1.0)
    variance = np.square(near) + w[:, None] * (np.square(far) - np.square(near))
    for got, expected in zip(innovation.noise_in_force(average, near, far), variance.T, strict=True):
        np.testing.assert_array_equal(got, np.sqrt(expected))


@pytest.mark.parametrize("sigma", [innovation.BEYOND_SIGMA, 3.0])
def test_a_surprise_clearly_within_sigma_is_neither_a_jump_nor_beyond_any_torque(sigma):
    """What :func:`kalman.clearly_within` lets the filter skip: both tests fail on every such reading."""
    rng = np.random.default_rng(1)
    root = rng.standard_normal((2000, 2, 2))
    S = root @ root.transpose(0, 2, 1) + 1e-3 * np.eye(2)
    S_inv = inverse_2x2(S)
    surprise = rng.standard_normal((2000, 2)) * rng.uniform(0.1, 10.0, (2000, 1))
    distance_sq = innovation.quadratic(surprise, S_inv, surprise)
    step = rng.standard_normal((2000, 2))
    step[:100] = surprise[:100]  # the surprise all along a step
    within = distance_sq < innovation.CLEAR_SHARE * sigma**2
    assert 100 < within.sum() < 1900
    assert not innovation.looks_like_a_jump(surprise, S_inv, distance_sq, step, sigma)[within].any()
    velocity_per_nm, limit = np.zeros(2000), np.zeros(2000)  # the tightest reach
    beyond = np.abs(surprise[:, 1]) > sigma * np.sqrt(S[:, 1, 1])
    assert not beyond[within].any()
    if sigma == innovation.BEYOND_SIGMA:
        assert not innovation.beyond_any_disturbance(surprise, S, velocity_per_nm, limit)[within].any()


@pytest.mark.parametrize("observer", [False, True])
@pytest.mark.parametrize("timing_s", [0.0, 0.01])
def test_one_joint_through_a_push_disagreement_and_a_restart(observer, timing_s):
    """The estimate stays near the arm while it agrees with the model; with the observer a push
    is taken as a jump and a reading beyond any torque restarts the filter."""
    dynamics = ArmDynamics(resources.default_urdf())
    kf = JointKalmanFilter(
        configs.kalman(command_timing_uncertainty_s=timing_s),
        1,
        dynamics.predict,
        transition=dynamics.transition,
        estimate_disturbance=observer,
        mass_matrix=dynamics.mass_matrix,
        disturbance_limit=np.array([10.0]),
        torque_scale=np.array([1.5]),
    )
    rng = np.random.default_rng(5)
    q, v, torque = np.zeros(1), np.zeros(1), np.zeros(1)
    errors = []
    for k in range(400):
        push = 3.0 if 150 <= k < 250 else 0.0
        q, v = dynamics.predict(q, v, torque, 0.01, 0.001, external_nm=np.array([push]))
        if k == 320:
            v = v + 40.0  # beyond any torque within the limit
        reading = (q + rng.normal(0.0, 0.005, 1), v + rng.normal(0.0, 0.02, 1))
        if 260 <= k < 300:
            reading = (reading[0] + 0.05 * (k - 260) / 40, reading[1])  # readings the model does not explain
        q_f, v_f = kf.update(0.01 * k, *reading, torque, np.abs(rng.normal(0.0, 1.0, 1)))
        assert np.all(np.isfinite(q_f)) and np.all(np.isfinite(kf.velocity_at_instant(q_f, v_f, torque)))
        if k < 150:
            errors.append(q_f[0] - q[0])
        torque = np.array([2.0 * np.sin(0.02 * k)])
    assert np.sqrt(np.mean(np.square(errors[50:]))) < 0.005  # better than the readings' σ
    if observer:
        assert kf.jump_count[0] >= 1 and kf.restart_count[0] >= 1
    else:
        assert kf.jump_count[0] == 0 and kf.restart_count[0] == 0


def test_a_payload_allowance_lets_the_observer_follow_a_load_turning_with_the_arm():
    """A torque that changes as a payload's gravity does while the arm turns (2 N·m, 0.5 Hz): with the payload's
    allowance the observer, mismatched, follows it closer than with the mismatch σ alone."""
    dynamics = ArmDynamics(resources.default_urdf())

    def disturbance_error(payload_torque_std):
        kf = JointKalmanFilter(
            configs.kalman(),
            1,
            dynamics.predict,
            transition=dynamics.transition,
            estimate_disturbance=True,
            mass_matrix=dynamics.mass_matrix,
            payload_torque_std=payload_torque_std,
        )
        rng = np.random.default_rng(2)
        q, v, torque, errors = np.zeros(1), np.zeros(1), np.zeros(1), []
        for k in range(600):
            load = np.array([2.0 * np.sin(np.pi * 0.01 * k)])
            q, v = dynamics.predict(q, v, torque, 0.01, 0.001, external_nm=load)
            kf.update(0.01 * k, q + rng.normal(0.0, 0.005, 1), v + rng.normal(0.0, 0.02, 1), torque)
            errors.append(kf.disturbance[0] - load[0])
            torque = dynamics.gravity(q) - 20.0 * q - 2.0 * v  # held about 0 by a PD on the truth
        return float(np.sqrt(np.mean(np.square(errors[100:]))))

    without, allowed = disturbance_error(None), disturbance_error(np.array([2.0 * np.pi]))
    assert allowed < 0.7 * without
