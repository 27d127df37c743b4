"""The loop told its drive's lag (``model_drive_lag_s``) tracks as if the drive had none: the controller inverts the
lag, so its law, filter and feedforward see the torque they ask for (in process: the graph's blocks)."""

from pathlib import Path

import pytest

from robot_controller import parameters as cfg
from robot_controller.experiments.inprocess import contained_controller, simulate
from robot_controller.parameters.builders import arm_model

LIGHT_ARM = str(Path(__file__).resolve().parents[2] / "examples" / "light_wrist_arm.urdf")


def rms_mrad(robot: str, lag_s: float, told_s: float) -> float:
    layer = {"motor_node": {"lag_time_constant_s": lag_s}, "pid_controller": {"model_drive_lag_s": told_s}}
    result = simulate(cfg.merge(cfg.load_stack(robot=robot), layer), duration_s=8.0, seed=0)
    return result.tracking_metrics()["tracking_rms_rad"] * 1e3


@pytest.mark.parametrize("robot", ["one_dof", LIGHT_ARM])
def test_a_lag_told_is_as_no_lag(robot):
    none, untold, told = rms_mrad(robot, 0.0, 0.0), rms_mrad(robot, 0.02, 0.0), rms_mrad(robot, 0.02, 0.02)
    assert untold > 2.5 * none  # 20 ms at 100 Hz: two periods of phase
    assert told == pytest.approx(none, rel=0.05)


def test_the_law_in_force_says_the_lag_it_inverts():
    ctrl = cfg.merge(cfg.load_stack(), {"pid_controller": {"model_drive_lag_s": 0.012}})["pid_controller"]
    controller = contained_controller(cfg.controller_config({**ctrl, cfg.WORLD_WAITS: True}, 1), 1, arm_model(ctrl))
    assert controller.law_in_force().endswith("; the drive's lag of 12 ms inverted")
