"""What names the robot, what its errors are called, and a connect that never gets an answer: one clear fault in
bounded time, never a run hanging on libfranka."""

import fcntl
import socket
import tempfile
import time
from pathlib import Path
from types import SimpleNamespace

import pytest

from robot_controller.hardware import franka_server
from robot_controller.hardware.franka_arm import FrankaArm, RobotFault, error_names, parse_hardware


def test_a_franka_is_named_by_its_host_alone():
    assert parse_hardware("franka://172.16.0.2") == "172.16.0.2"
    assert parse_hardware("franka://robot.local/") == "robot.local"
    for wrong in ("172.16.0.2", "tcp://172.16.0.2", "franka://", "franka://host:1337", "franka://host/arm"):
        with pytest.raises(ValueError, match="franka://"):
            parse_hardware(wrong)


def test_the_errors_set_are_named_as_libfranka_names_them():
    errors = SimpleNamespace(joint_velocity_violation=True, tau_j_range_violation=False, cartesian_reflex=True)
    assert error_names(errors) == ["cartesian_reflex", "joint_velocity_violation"]


def test_a_robot_that_never_answers_is_a_fault_within_the_timeout_not_a_hang():
    pytest.importorskip("pylibfranka", reason="the franka extra: pip install -e '.[dev]'")
    # A listener on libfranka's port that takes the connection and says nothing, as a robot busy with another
    # client does; the stand-ins' lock keeps them off the port meanwhile.
    lock = (Path(tempfile.gettempdir()) / f"franka-sim-{franka_server.COMMAND_PORT}.lock").open("a")
    fcntl.flock(lock, fcntl.LOCK_EX)
    silent = socket.socket()
    try:
        silent.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            silent.bind((franka_server.HOST, franka_server.COMMAND_PORT))
        except OSError as exc:
            pytest.skip(f"port {franka_server.COMMAND_PORT} is taken here: {exc}")
        silent.listen(1)
        started = time.monotonic()
        with pytest.raises(RobotFault, match="did not answer in 1 s"):
            FrankaArm(franka_server.HOST, connect_timeout_s=1.0)
        assert time.monotonic() - started < 30.0  # (a bound on a hang, not a speed)
    finally:
        silent.close()
        lock.close()
