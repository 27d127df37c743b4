"""pid_controller: the law ``controller_type`` selects at ``control_rate_hz``, from the ports ``reading`` and
``reference`` to ``command``, ``state`` and ``diagnostics`` (``blocks.spec``)."""

from robot_controller.nodes.pid_controller.node import ControllerNode, main

__all__ = ["ControllerNode", "main"]
