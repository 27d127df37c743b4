"""The rclpy benchmarks (two-process round trips, a message's CPU in one process) run and give a figure."""

import math

import pytest

from robot_controller_lab.hop_bench import message_cpu_s, round_trips_per_s

pytestmark = pytest.mark.ros


def test_round_trips_per_s_is_a_positive_rate(ros_domain):
    # No threshold: the figure depends on the machine and its load.
    rate = round_trips_per_s(duration_s=1.0, domain_id=ros_domain)
    assert math.isfinite(rate) and rate > 0


def test_message_cpu_s_is_a_positive_cost(ros_domain):
    # No threshold either: what a message costs is the machine's.
    cpu_s = message_cpu_s(duration_s=1.0, domain_id=ros_domain)
    assert math.isfinite(cpu_s) and cpu_s > 0
