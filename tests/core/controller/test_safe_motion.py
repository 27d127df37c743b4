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
