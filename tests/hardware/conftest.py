"""The stand-in Franka robot (franka-sim, our Panda inside) for the tests that drive it through libfranka."""

import os

import pytest

from robot_controller.hardware import franka_server
from tests.hardware.stand_in import stand_in_venv


@pytest.fixture(scope="module")
def stand_in(tmp_path_factory):
    """One stand-in for a module's tests, its communication constraints and motion limits enforced (a late command
    or a joint past its limits is the robot's reflex, as on a real arm)."""
    pytest.importorskip("pylibfranka", reason="the franka extra: pip install -e '.[dev]'")
    venv = stand_in_venv()
    mjcf = franka_server.write_panda_mjcf(tmp_path_factory.mktemp("stand_in"))
    flags = ("--enforce-comm-constraints", "--enforce-motion-limits")
    with franka_server.FrankaServer(mjcf, venv=venv, flags=flags) as server:
        yield server


@pytest.fixture(autouse=True)
def session_scheduling_kept():
    """libfranka makes the thread that connects SCHED_FIFO 99 where it can: left so, every process the test session
    starts after inherits it (a split run's nodes spun at priority 99 and starved the host). Put back, and failed."""
    yield
    policy = os.sched_getscheduler(0)
    if policy != os.SCHED_OTHER:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
        pytest.fail(f"the test left the session's thread at scheduling policy {policy} (put back to SCHED_OTHER)")
