"""pid_controller: the control law at ``control_rate_hz``, whatever law ``controller_type`` selects.

Reads ``/joint_states`` and ``/trajectory``, publishes one torque per joint on
``/joint_commands``, every term on ``/controller/state`` and its loop timing on
``/diagnostics``. The maths is ``core.controller.JointController``."""

from robot_controller.nodes.pid_controller.node import PidControllerNode, main

__all__ = ["PidControllerNode", "main"]
