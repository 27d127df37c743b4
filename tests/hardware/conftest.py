"""The stand-in Franka robot (franka-sim, our Panda inside) for the tests that drive it through libfranka."""

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
