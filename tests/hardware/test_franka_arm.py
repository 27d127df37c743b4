"""What names the robot, and what its errors are called."""

from types import SimpleNamespace

import pytest

from robot_controller.hardware.franka_arm import error_names, parse_hardware


def test_a_franka_is_named_by_its_host_alone():
    assert parse_hardware("franka://172.16.0.2") == "172.16.0.2"
    assert parse_hardware("franka://robot.local/") == "robot.local"
    for wrong in ("172.16.0.2", "tcp://172.16.0.2", "franka://", "franka://host:1337", "franka://host/arm"):
        with pytest.raises(ValueError, match="franka://"):
            parse_hardware(wrong)


def test_the_errors_set_are_named_as_libfranka_names_them():
    errors = SimpleNamespace(joint_velocity_violation=True, tau_j_range_violation=False, cartesian_reflex=True)
    assert error_names(errors) == ["cartesian_reflex", "joint_velocity_violation"]
