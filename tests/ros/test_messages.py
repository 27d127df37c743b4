"""Messages in and out: checks on incoming joint states, trajectory samples and efforts, and the
tick stamp a command carries in its layout (no ROS graph: the message classes alone)."""

import numpy as np
import pytest
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller.blocks.values import (
    Array,
    at_tick,
    brake_reasons,
    brakes_label,
    check_effort,
    check_joint_state,
    check_trajectory,
    labelled_tick_s,
    tick_label,
)
from robot_controller.ros.messages import decode, encode


def command_tick_s(msg: Float64MultiArray) -> float | None:
    return labelled_tick_s(decode(msg).label)


def msg_brake_reasons(msg: Float64MultiArray) -> set[str] | None:
    return brake_reasons(decode(msg).label)


@pytest.mark.parametrize(
    "names, pos, vel, ok",
    [
        (["joint1"], [0.1], [0.2], True),
        ([], [0.1], [0.2], True),
        (["joint1"], [], [], False),
        (["joint1"], [0.1, 0.2], [0.2], False),
        (["elbow"], [0.1], [0.2], False),
        (["joint1"], [float("nan")], [0.0], False),
        (["joint1"], [0.0], [float("inf")], False),
    ],
)
def test_joint_state_check(names, pos, vel, ok):
    result = check_joint_state(names, pos, vel, ["joint1"])
    assert (not isinstance(result, str)) == ok


def test_trajectory_and_effort_checks():
    assert not isinstance(check_trajectory([0.1, 0.2, 0.3], 1), str)
    p, v, a, sample_time = check_trajectory([0.1, 0.2], 1)  # the tutorial's [position, velocity]
    assert a[0] == 0.0 and sample_time is None
    assert check_trajectory([0.1, 0.2, 0.3, 12.5], 1)[3] == 12.5  # ours: with the sample time
    assert isinstance(check_trajectory([0.1, 0.2, 0.3, float("nan")], 1), str)
    assert isinstance(check_trajectory([0.1], 1), str)
    assert isinstance(check_trajectory([0.1, float("nan"), 0.0], 1), str)
    assert isinstance(check_effort([1.0, 2.0], 1), str)
    assert isinstance(check_effort([float("inf")], 1), str)


def test_a_stamped_command_says_its_tick_and_keeps_its_data():
    msg = encode(Array(np.array([1.5, -2.0]), tick_label(1_795_756_083.344798)), Float64MultiArray())
    assert command_tick_s(msg) == pytest.approx(1_795_756_083.344798, abs=1e-6)  # a float's resolution there
    assert list(msg.data) == [1.5, -2.0] and msg.layout.dim[0].size == 2
    encode(Array(np.array([1.5, -2.0]), tick_label(12.0)), msg)  # the message is reused tick after tick
    assert command_tick_s(msg) == 12.0 and len(msg.layout.dim) == 1


def test_a_command_carries_its_tick_as_a_number_beside_its_label():
    value = decode(encode(at_tick(np.array([1.0]), 12.345), Float64MultiArray()))  # read from the label once
    assert value.label == tick_label(12.345) and value.tick_s == labelled_tick_s(value.label) == pytest.approx(12.345)
    assert Array(np.zeros(1), brakes_label({"estop"})).tick_s is None and Array(np.zeros(1)).tick_s is None


def test_a_command_without_the_stamp_says_nothing():
    assert command_tick_s(Float64MultiArray(data=[1.0])) is None  # the tutorial's controller
    labelled = Float64MultiArray(data=[1.0])
    labelled.layout.dim = [MultiArrayDimension(label="joints", size=1, stride=1)]
    assert command_tick_s(labelled) is None
    labelled.layout.dim[0].label = "tick_ns:soon"
    assert command_tick_s(labelled) is None


def test_the_brakes_say_why_they_hold_and_a_label_not_ours_says_nothing():
    msg = Float64MultiArray(data=[1.0])
    msg.layout.dim = [MultiArrayDimension(label=brakes_label({"start", "estop"}), size=1, stride=1)]
    assert msg_brake_reasons(msg) == {"start", "estop"}
    msg.layout.dim[0].label = brakes_label(set())
    assert msg_brake_reasons(msg) == set()
    msg.layout.dim[0].label = "engaged"  # an older simulator's
    assert msg_brake_reasons(msg) is None
    assert msg_brake_reasons(Float64MultiArray(data=[0.0])) is None
