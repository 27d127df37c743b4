"""simulator: the physics world (the Gazebo role). MuJoCo steps the arm from the URDF at ``physics_rate_hz`` on the
latest ``/sim/effort``; the true state goes out on ``/sim/joint_states``, stamped with its physics time."""

from robot_controller.nodes.simulator.node import Simulator, main

__all__ = ["Simulator", "main"]
