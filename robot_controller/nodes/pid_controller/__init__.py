"""pid_controller: the law ``controller_type`` selects at ``control_rate_hz``, from ``/joint_states`` and
``/trajectory`` to ``/joint_commands``, ``/controller/state`` and ``/diagnostics``."""

from robot_controller.nodes.pid_controller.node import PidControllerNode, main

__all__ = ["PidControllerNode", "main"]
