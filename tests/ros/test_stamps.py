"""The tick stamp a command carries in its layout (no ROS graph: the message class alone)."""

import pytest
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller.ros.stamps import command_tick_s, stamp_command


def test_a_stamped_command_says_its_tick_and_keeps_its_data():
    msg = Float64MultiArray(data=[1.5, -2.0])
    stamp_command(msg, 1_795_756_083.344798)
    assert command_tick_s(msg) == pytest.approx(1_795_756_083.344798, abs=1e-6)  # a float's resolution there
    assert list(msg.data) == [1.5, -2.0] and msg.layout.dim[0].size == 2
    stamp_command(msg, 12.0)  # the message is reused tick after tick
    assert command_tick_s(msg) == 12.0 and len(msg.layout.dim) == 1


def test_a_command_without_the_stamp_says_nothing():
    assert command_tick_s(Float64MultiArray(data=[1.0])) is None  # the tutorial's controller
    labelled = Float64MultiArray(data=[1.0])
    labelled.layout.dim = [MultiArrayDimension(label="joints", size=1, stride=1)]
    assert command_tick_s(labelled) is None
    labelled.layout.dim[0].label = "tick_ns:soon"
    assert command_tick_s(labelled) is None
