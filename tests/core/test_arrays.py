"""The per-tick shortcuts give what the NumPy calls they stand for give: to the
bit where they compute the same thing, to rounding where they compute it
another way (closed forms, one product for a sum of terms)."""

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from robot_controller.core.controller.safe_motion import Blend, _quintic
from robot_controller.core.estimation import innovation
from robot_controller.core.estimation.estimator import KalmanConfig, _solve_symmetric, inverse_2x2, process_noise

values = st.floats(allow_nan=True, allow_infinity=True, width=64)
finite = st.floats(min_value=-1e6, max_value=1e6)


def vector(elements=values, size=3):
    return st.lists(elements, min_size=size, max_size=size).map(np.array)


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
    Q = process_noise(KalmanConfig(), dt, b, sigma_d, sigma_a)
    a2, w = sigma_a**2, sigma_d**2
    expected = np.zeros((2, 3, 3))
    expected[:, 0, 0] = dt**4 / 4 * a2 + w * b * b * dt**5 / 20
    expected[:, 0, 1] = expected[:, 1, 0] = dt**3 / 2 * a2 + w * b * b * dt**4 / 8
    expected[:, 1, 1] = dt**2 * a2 + w * b * b * dt**3 / 3
    expected[:, 0, 2] = expected[:, 2, 0] = w * b * dt**3 / 6
    expected[:, 1, 2] = expected[:, 2, 1] = w * b * dt**2 / 2
    expected[:, 2, 2] = w * dt
    np.testing.assert_allclose(Q, expected, rtol=1e-13, atol=0)


@given(vector(st.floats(min_value=0.0, max_value=10.0)))
def test_noise_in_force_while_agreeing_is_the_general_formula(average):
    near, far = (1e-4, 5e-3), (0.3, 2.0)
    w = np.clip((average - innovation.MISMATCH_FROM) / innovation.MISMATCH_SPAN, 0.0, 1.0)
    variance = np.square(near) + w[:, None] * (np.square(far) - np.square(near))
    for got, expected in zip(innovation.noise_in_force(average, near, far), variance.T, strict=True):
        np.testing.assert_array_equal(got, np.sqrt(expected))


def peak_acceleration(p0, v0, duration_s):
    """The blend's largest |acceleration| over 41 instants, taken one at a time."""
    return max(float(np.max(np.abs(_quintic(p0, v0, duration_s, s * duration_s)[2]))) for s in np.linspace(0, 1, 41))


def test_blend_is_the_shortest_within_the_acceleration_one_instant_at_a_time_finds():
    p0, v0 = np.array([0.3, -0.1]), np.array([2.0, 0.5])
    blend = Blend.starting(0.0, p0, v0, 20.0)
    assert blend.duration_s > 0.2  # it had to be lengthened
    assert peak_acceleration(p0, v0, blend.duration_s) <= 20.0
    assert peak_acceleration(p0, v0, blend.duration_s / 1.25) > 20.0


def test_solve_symmetric_for_one_joint_is_lapacks():
    rng = np.random.default_rng(1)
    root = rng.standard_normal((2, 2))
    S, B = root @ root.T + 0.1 * np.eye(2), rng.standard_normal((2, 3))
    np.testing.assert_allclose(_solve_symmetric(S, B), np.linalg.solve(S, B), rtol=1e-12, atol=1e-15)
