"""The in-process loop's record scored in each joint's unit (``LoopResult.tracking_metrics``)."""

from __future__ import annotations

from robot_controller import parameters as cfg
from robot_controller.experiments import inprocess


def test_the_scara_quill_is_scored_in_metres_beside_its_revolute_joints():
    result = inprocess.simulate(cfg.load_stack(robot="scara"), duration_s=3.0, seed=0)
    assert result.joint_units == ["rad", "rad", "m"]
    figures = result.tracking_metrics()
    rms = figures["tracking_rms_per_joint"]
    assert figures["tracking_rms_rad"] == max(rms[:2]) and figures["tracking_rms_m"] == rms[2] < 0.001
    assert "tracking_rms_rad_per_joint" not in figures  # a list mixing rad and m under a rad name
