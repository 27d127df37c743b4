"""The two-process rclpy round-trip benchmark runs and gives a figure."""

import math

import pytest

from robot_controller_lab.hop_bench import round_trips_per_s

pytestmark = pytest.mark.ros


def test_round_trips_per_s_is_a_positive_rate(ros_domain):
    # No threshold: the figure depends on the machine and its load.
    rate = round_trips_per_s(duration_s=1.0, domain_id=ros_domain)
    assert math.isfinite(rate) and rate > 0
