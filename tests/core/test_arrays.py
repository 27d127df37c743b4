"""The per-tick shortcuts give what the NumPy calls they stand for give: to the
bit where they compute the same thing, to rounding where they compute it
another way (closed forms, one product for a sum of terms)."""

import numpy as np
from hypothesis import strategies as st

from robot_controller.core.controller.safe_motion import Blend, _quintic

values = st.floats(allow_nan=True, allow_infinity=True, width=64)
finite = st.floats(min_value=-1e6, max_value=1e6)


def vector(elements=values, size=3):
    return st.lists(elements, min_size=size, max_size=size).map(np.array)


def peak_acceleration(p0, v0, duration_s):
    """The blend's largest |acceleration| over 41 instants, taken one at a time."""
    return max(float(np.max(np.abs(_quintic(p0, v0, duration_s, s * duration_s)[2]))) for s in np.linspace(0, 1, 41))


def test_blend_is_the_shortest_within_the_acceleration_one_instant_at_a_time_finds():
    p0, v0 = np.array([0.3, -0.1]), np.array([2.0, 0.5])
    blend = Blend.starting(0.0, p0, v0, 20.0)
    assert blend.duration_s > 0.2  # it had to be lengthened
    assert peak_acceleration(p0, v0, blend.duration_s) <= 20.0
    assert peak_acceleration(p0, v0, blend.duration_s / 1.25) > 20.0

