"""Checks on incoming joint states, trajectory samples and efforts (no ROS)."""

import pytest

from robot_controller.core.validation import check_effort, check_joint_state, check_trajectory


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
