"""simulator: the physics world (the Gazebo role). MuJoCo steps the arm
from the URDF at ``physics_rate_hz`` applying the latest ``/sim/effort``;
the true state goes out on ``/sim/joint_states``, stamped with its physics
time.

The node is assembled from one module per concern:

- ``node``: the node shell (parameters, the effort input, the true state out);
- ``pacing``: the wall clock, a pacing thread on absolute deadlines;
- ``brakes``: the drive's holding brakes, the e-stop and the drive timeout;
- ``lockstep``: sim time, one control period per effort;
- ``disturbance``: external torques applied in the physics beside the drive's.

The physics is ``core.plant``; the kept arm state is ``world_state``.
"""

from robot_controller.nodes.simulator.node import Simulator, main

__all__ = ["Simulator", "main"]
