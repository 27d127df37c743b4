"""The one-joint float paths (PID, Kalman filter) give what their array paths give, to rounding, in every
mode; and the collision pass skipped where no contact can happen changes nothing (no ROS)."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.estimation.estimator import JointKalmanFilter, KalmanConfig, _power_2x2
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource, Pid, PidConfig
from robot_controller.core.model import (
    ArmDynamics,
)


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


@pytest.mark.parametrize("observer", [False, True])
@pytest.mark.parametrize("timing_s", [0.0, 0.01])
def test_one_joint_filter_is_the_array_filter(dynamics, observer, timing_s):
    """Through agreement, a push (a jump), disagreement and a reading beyond any torque (a restart);
    the arm model asked through its array calls."""

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

    floats, arrays = make(), make()
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


def test_power_of_a_2x2_on_floats_is_matrix_power():
    rng = np.random.default_rng(0)
    for k in range(1, 25):
        a = rng.normal(size=(2, 2))
        np.testing.assert_allclose(_power_2x2(a.ravel().tolist(), k), np.linalg.matrix_power(a, k).ravel(), rtol=1e-12)
