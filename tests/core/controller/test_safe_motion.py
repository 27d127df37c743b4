"""The blend back onto the trajectory: the shortest within the acceleration limit."""

import numpy as np

from robot_controller.core.controller.safe_motion import Blend, _quintic


def peak_acceleration(p0, v0, duration_s):
    """The blend's largest |acceleration| over 41 instants, taken one at a time."""
    return max(float(np.max(np.abs(_quintic(p0, v0, duration_s, s * duration_s)[2]))) for s in np.linspace(0, 1, 41))


def test_blend_is_the_shortest_within_the_acceleration_one_instant_at_a_time_finds():
    p0, v0 = np.array([0.3, -0.1]), np.array([2.0, 0.5])
    blend = Blend.starting(0.0, p0, v0, 20.0)
    assert blend.duration_s > 0.2  # it had to be lengthened
    assert peak_acceleration(p0, v0, blend.duration_s) <= 20.0
    assert peak_acceleration(p0, v0, blend.duration_s / 1.25) > 20.0


def test_a_smooth_stop_starts_where_the_motion_is_and_rests_without_a_step():
    from robot_controller.core.controller.safe_motion import SmoothStop

    p0, v0, a0 = np.array([0.1, -0.4]), np.array([1.2, -0.5]), np.array([-8.0, 1.0])
    stop = SmoothStop.starting(2.0, p0, v0, a0, 4.0)
    for got, want in zip(stop.at(2.0), (p0, v0, a0), strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)  # position, speed and acceleration continuous
    times = 2.0 + np.linspace(0.0, stop.duration_s, 501)
    acceleration = np.array([stop.at(t)[2] for t in times])
    assert np.all(np.abs(acceleration) <= np.maximum(4.0, np.abs(a0)) + 1e-9)
    assert stop.at_rest(2.0 + stop.duration_s) and not stop.at_rest(2.0 + stop.duration_s / 2)
    end = stop.at(2.0 + stop.duration_s + 1.0)
    np.testing.assert_allclose(end[1:], np.zeros((2, 2)), atol=1e-9)
    np.testing.assert_allclose(end[0], stop.at(2.0 + stop.duration_s)[0])  # held
