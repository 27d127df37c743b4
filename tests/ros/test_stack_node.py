"""A stack node refuses a change to a read-only parameter through its parameter services with the
reason (rclpy's own names the parameter only), and keeps the value in force."""

import pytest
import rclpy
from rclpy.parameter import Parameter

from robot_controller.nodes.motor_node import MotorNode

pytestmark = pytest.mark.ros


def test_a_safety_setting_is_refused_at_run_time_with_the_reason_and_keeps_its_value(ros_domain):
    rclpy.init(args=["--ros-args", "-p", "command_timeout_s:=0.1"], domain_id=ros_domain)
    try:
        node = MotorNode()
        refused = node.set_parameters_atomically([Parameter("command_timeout_s", Parameter.Type.DOUBLE, 10.0)])
        assert not refused.successful
        assert refused.reason == "command_timeout_s: safety setting: set it in the run's config, not at run time"
        assert node.get_parameter("command_timeout_s").value == 0.1 and node.params["command_timeout_s"] == 0.1
        assert node.describe_parameter("command_timeout_s").read_only  # as ros2 param describe shows it
        fixed = node.set_parameters_atomically([Parameter("urdf_path", Parameter.Type.STRING, "other.urdf")])
        assert not fixed.successful and fixed.reason.startswith("urdf_path: read-only: fixed when the node starts")
        # Both in one request: nothing changes.
        lag, timeout = Parameter("lag_time_constant_s", value=0.01), Parameter("command_timeout_s", value=0.2)
        assert not node.set_parameters_atomically([lag, timeout]).successful
        assert node.get_parameter("lag_time_constant_s").value == 0.0
        assert node.set_parameters_atomically([lag]).successful  # what is not read-only stays live
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
