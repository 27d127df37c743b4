"""The drive's decisions, on a robot that stands still (no libfranka, no ROS): what ends the motion and how the robot
is left: the run's end and an e-stop stop it smoothly, then let it go or brake it; a link that loses too many commands
stops it under control; a reflex ends it at once."""

import numpy as np
import pytest

from robot_controller.blocks.block import Lines
from robot_controller.blocks.controller_reports import Reports
from robot_controller.hardware.franka_arm import ROTOR_INERTIA_KGM2, RobotFault, RobotReading
from robot_controller.hardware.robot_drive import Drive
from robot_controller.hardware.robot_link import END, ESTOP, RobotLink
from robot_controller.hardware.robot_loop import robot_loop
from robot_controller.parameters.files import load_stack

HOME = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])


class StillRobot:
    """A robot whose arm stays at ``HOME``, a state every 1 ms; ``on_tick(k, link)`` runs before each."""

    def __init__(self, link: RobotLink, on_tick=lambda k, link: None, success=lambda k: 1.0) -> None:
        self.link, self.on_tick, self.success = link, on_tick, success
        self.k = 0
        self.sent: list[np.ndarray] = []
        self.ended_by: str | None = None

    def position(self) -> np.ndarray:
        return HOME.copy()

    def start(self) -> RobotReading:
        return self.read()

    def read(self) -> RobotReading:
        self.on_tick(self.k, self.link)
        t = self.k * 1e-3
        self.k += 1
        zeros = np.zeros(7)
        return RobotReading(t, 1000.0 + t, t, 0, HOME.copy(), zeros, zeros, zeros, self.success(self.k))

    def write(self, torque_nm: np.ndarray) -> None:
        assert np.all(np.isfinite(torque_nm))
        self.sent.append(torque_nm)

    def finish(self) -> None:
        self.ended_by = "finish"

    def stop(self) -> None:
        self.ended_by = "stop"


@pytest.fixture(scope="module")
def parts():
    loop = robot_loop(load_stack(robot="panda"), ROTOR_INERTIA_KGM2)
    reports = Reports(Lines(), loop.controller, world_waits=False)
    return loop, reports


def drive_with(parts, **robot_kwargs):
    loop, reports = parts
    link = RobotLink(7, sum(size for _, size in reports.state_blocks))
    link.offer_reference(1000.0, np.concatenate([HOME, np.zeros(14)]))
    robot = StillRobot(link, **robot_kwargs)
    return Drive(loop, robot, link, reports, clock_offset_s=0.0, stop_deceleration=4.0), robot, link


@pytest.mark.parametrize(("flag", "why", "left"), [(END, "end", "finish"), (ESTOP, "estop", "stop")])
def test_the_end_and_an_e_stop_stop_the_arm_then_let_it_go_or_brake_it(parts, flag, why, left):
    drive, robot, link = drive_with(parts, on_tick=lambda k, link: k == 200 and link.request(flag))
    end = drive.run()
    assert end.why == why and end.fault is None
    assert robot.ended_by == left
    assert link.phase() == "stopping"
    assert 200 < robot.k < 2000, "at rest already: the smooth stop is short, then 50 ticks at rest"


def test_a_robot_taking_too_few_commands_in_time_is_stopped_under_control(parts):
    drive, robot, link = drive_with(parts, success=lambda k: 1.0 if k < 300 else 0.4)
    end = drive.run()
    assert end.why == "link" and drive.success_rate_low == pytest.approx(0.4)
    assert robot.ended_by == "finish"


def test_a_reflex_ends_the_motion_at_once(parts):
    def reflex(k, link):
        if k == 100:
            raise RobotFault(["joint_velocity_violation"], "libfranka: Move command aborted: motion aborted by reflex!")

    drive, robot, link = drive_with(parts, on_tick=reflex)
    end = drive.run()
    assert end.why == "fault" and "joint_velocity_violation" in end.fault.describe()
    assert robot.ended_by is None, "the robot stopped itself: nothing more is sent"
