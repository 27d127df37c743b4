"""pid_controller itself (one node, no graph): it declares its law's parameters law.NAME, takes
them from its overrides, refuses one the law does not declare or a value out of range with the
reason, and passes a new value to the law while running."""

from pathlib import Path

import pytest
import rclpy
from rclpy.parameter import Parameter

from robot_controller.core.errors import ConfigError
from robot_controller.nodes.pid_controller import ControllerNode

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
EXAMPLE = "examples/own_controller.py:PDWithGravity"


def start(domain: int, *overrides: str) -> ControllerNode:
    args = ["--ros-args", "-p", f"controller_type:={EXAMPLE}"] + [a for o in overrides for a in ("-p", o)]
    rclpy.init(args=args, domain_id=domain)
    return ControllerNode()


def test_the_controller_declares_checks_and_applies_its_laws_parameters(ros_domain, monkeypatch):
    monkeypatch.chdir(ROOT)  # a relative law file, from where the node runs
    try:
        node = start(ros_domain, "law.natural_frequency_hz:=5.0")
        assert node.get_parameter("law.natural_frequency_hz").value == 5.0
        assert node.get_parameter("law.damping_ratio").value == 1.0  # the law's default
        assert "closed-loop bandwidth" in node.describe_parameter("law.natural_frequency_hz").description
        refused = node.set_parameters([Parameter("law.natural_frequency_hz", Parameter.Type.DOUBLE, 99.0)])[0]
        assert not refused.successful and "law.natural_frequency_hz: must be <= 30, got 99" in refused.reason
        took = node.set_parameters([Parameter("law.natural_frequency_hz", Parameter.Type.DOUBLE, 6.0)])[0]
        assert took.successful, took.reason
        node.extras.tick(0.0)  # the next tick takes it over first
        assert node.block.controller.plugin.law.params["natural_frequency_hz"] == 6.0
        assert "natural_frequency_hz=6" in node.get_parameter("law_in_force").value
        changed = node.set_parameters([Parameter("controller_type", Parameter.Type.STRING, "pid")])[0]
        assert not changed.successful and "chosen when the controller starts" in changed.reason
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    try:
        with pytest.raises(ConfigError, match="pid_controller.law.gain: the law PDWithGravity declares no such"):
            start(ros_domain, "law.gain:=1.0")
    finally:
        rclpy.try_shutdown()
