"""pid_controller: the control law at ``control_rate_hz``.

Reads ``/joint_states`` (noisy) and ``/trajectory``, publishes one torque per
joint on ``/joint_commands``, every term on ``/controller/state`` and its own
loop health on ``/diagnostics``. The maths is ``core.controller.JointController``.

The node is assembled from one module per concern:

- ``node``: the node shell (parameters, the inputs, the two triggers, the tick);
- ``lockstep``: readings paired with ticks on the sim's ``/clock``;
- ``health``: the command path's delay, the late loop's line, ``/diagnostics``;
- ``status``: the law in force, changes of the loop's state, a failed law's
  stop, ``/controller/state``.
"""

from robot_controller.nodes.pid_controller.node import PidControllerNode, main

__all__ = ["PidControllerNode", "main"]
